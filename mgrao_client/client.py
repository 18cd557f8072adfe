"""The client: :class:`Client` opens runs, :class:`LoggedRun` buffers episodes and uploads them in batches."""

from __future__ import annotations

import hashlib
import json
import math
import time
import urllib.error
import urllib.request
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

DEFAULT_URL = "http://127.0.0.1:8000"
RETRY_STATUSES = frozenset({429, 502, 503, 504})
"""Answers after which a request is sent again (the database busy or unavailable, a proxy's hiccup)."""
BODY_MARGIN = 256
"""Bytes of a batch's body kept for its key and its brackets."""


class ApiError(Exception):
    """The service refused a request: ``status`` (HTTP), ``detail`` (its answer's detail) and a readable message."""

    def __init__(self, status: int, detail: Any, method: str, path: str) -> None:
        self.status, self.detail = status, detail
        if isinstance(detail, list):
            text = "; ".join(str(d.get("msg", d)) if isinstance(d, dict) else str(d) for d in detail)
        else:
            text = str(detail)
        super().__init__(f"{method} {path}: {status}: {text}")


class ServiceUnavailable(Exception):
    """No answer from the service after every retry (not running, wrong URL, down for longer than the retries)."""


def _floats(values: Iterable[Any], what: str, first: int = 0) -> list[str]:
    """Each value as JSON number text; a value that is not a finite number is refused, naming ``what`` and its index."""
    out = []
    for i, value in enumerate(values):
        number = float(value)
        if not math.isfinite(number):
            raise ValueError(f"{what}: value {first + i} is {number!r}: utilities and weights must be finite numbers")
        out.append(repr(number))
    return out


class Client:
    """One MG-RAO service: its base URL and API token (``MGRAO_API_TOKEN`` of the service, if it has one).

    Args:
        url: the service's base URL (``mgrao serve`` listens on http://127.0.0.1:8000).
        token: the bearer token, or None.
        timeout: seconds to wait for one answer.
        retries: times a request is sent again after a lost connection, a timeout or a 429/502/503/504
            (a batch is sent again under its key, so it is never stored twice).
        backoff: seconds before the first retry; doubled after each, at most 10 s.
    """

    def __init__(self, url: str = DEFAULT_URL, token: str | None = None, *, timeout: float = 30.0,
                 retries: int = 5, backoff: float = 0.25) -> None:
        self.url = url.rstrip("/")
        self.token = token
        self.timeout, self.retries, self.backoff = timeout, retries, backoff

    def request(self, method: str, path: str, body: bytes | None = None) -> tuple[int, Any]:
        """``(status, JSON answer)`` of ``method path`` with a JSON ``body``, retried as the class says.

        Raises:
            ApiError: any other answer than 2xx (after the retries for those retried).
            ServiceUnavailable: no answer after the retries.
        """
        headers = {"Content-Type": "application/json", "Accept": "application/json"}
        if self.token:
            headers["Authorization"] = f"Bearer {self.token}"
        delay = self.backoff
        for attempt in range(self.retries + 1):
            last = attempt == self.retries
            request = urllib.request.Request(self.url + path, data=body, method=method, headers=headers)
            try:
                with urllib.request.urlopen(request, timeout=self.timeout) as response:  # noqa: S310 - the user's service
                    return response.status, json.loads(response.read() or b"null")
            except urllib.error.HTTPError as error:
                try:
                    detail = json.loads(error.read()).get("detail")
                except (ValueError, AttributeError):
                    detail = error.reason
                if error.code not in RETRY_STATUSES or last:
                    raise ApiError(error.code, detail, method, path) from None
                wait = error.headers.get("Retry-After")
                pause = float(wait) if wait and wait.isdigit() else delay
            except (urllib.error.URLError, OSError) as error:  # refused, reset, timed out
                if last:
                    reason = getattr(error, "reason", error)
                    raise ServiceUnavailable(f"no answer from the MG-RAO service at {self.url} ({reason}) after "
                                             f"{self.retries + 1} attempts") from None
                pause = delay
            time.sleep(min(pause, 10.0))
            delay = min(delay * 2, 10.0)
        raise AssertionError("unreachable")  # pragma: no cover

    def open_run(self, *, label: str, system: str, episodes: int, seeds: int | Sequence[int] = 30,
                 params: Mapping[str, Any] | None = None, name: str = "", tags: Sequence[str] = (),
                 notes: str = "", key: str | None = None) -> LoggedRun:
        """Open a run logged from outside (``POST /api/external-runs``).

        Args:
            label: the configuration's name beside the built-in ones: 1-32 characters, a lowercase letter
                then lowercase letters, digits, ``.``, ``_`` or ``-``, and no built-in algorithm's label.
            system: a preset (``single``, ``multi``, ``volatile``, ``large``).
            episodes: episodes per seed (every seed must get exactly this many before ``close``).
            seeds: a count S (seeds 0 .. S-1) or the list of seeds, as a job's: the same seed is the same
                world as the engine's, so compare pairs them with built-in runs seed by seed.
            params: parameter overrides of the preset (``GET /api/systems`` lists them), as a job's.
            name: the job's name in the dashboard.
            tags: the job's tags.
            notes: the job's notes.
            key: opening again with the same key and definition answers the same run (resume after a
                crash); 1-64 letters, digits, ``.``, ``_``, ``:`` or ``-``.

        Raises:
            ApiError: 422 naming the refused field (a label that is a built-in's, an unknown parameter...).
        """
        body: dict[str, Any] = {"label": label, "system": system, "episodes": episodes,
                                "seeds": seeds if isinstance(seeds, int) else list(seeds),
                                "params": dict(params or {}), "name": name, "tags": list(tags), "notes": notes}
        if key is not None:
            body["key"] = key
        status, answer = self.request("POST", "/api/external-runs", json.dumps(body).encode())
        return LoggedRun(self, answer, resumed=status == 200)

    def run(self, run_id: int) -> LoggedRun:
        """An external run opened earlier (``GET /api/external-runs/{id}``), to send more batches or close it."""
        _, answer = self.request("GET", f"/api/external-runs/{run_id}")
        return LoggedRun(self, answer, resumed=True)


class LoggedRun:
    """An open external run: ``log`` episode utilities and ``log_weights``, then ``close``.

    Also a context manager: leaving the block normally closes the run; leaving it on an exception
    uploads what is buffered and leaves the run open (shown as ``open`` in the dashboard).

    Attributes:
        id: the run's job id (``/#/jobs/{id}`` in the dashboard).
        label, system, seeds, episodes: its definition.
        resumed: whether the service answered a run already opened with the same key.
        state: the service's last answer about the run.
    """

    def __init__(self, client: Client, answer: dict[str, Any], resumed: bool = False) -> None:
        self.client = client
        self.state = answer
        job = answer["job"]
        self.id: int = job["id"]
        self.label: str = answer["label"]
        self.system: str = job["system"]
        self.seeds: list[int] = list(job["seeds"])
        self.episodes: int = job["episodes"]
        self.resumed = resumed
        limits = answer["limits"]
        self.batch_bytes = max(1024, limits["max_body_bytes"] - BODY_MARGIN)
        self.max_entries: int = limits["max_batch_entries"]
        self.max_piece_values: int = limits.get("max_piece_values", 10_000)
        self.weights_shape: tuple[int, int] = tuple(limits["weights_shape"])
        self.batches = 0
        self.replayed = 0
        self._seed_set = set(self.seeds)
        self._next: dict[int, int] = {}
        self._held: dict[int, str] = {}  # seed -> weights entry, until its episodes are all logged
        self._entries: list[str] = []
        self._weights: list[str] = []
        self._size = 0

    # ---- logging ----------------------------------------------------------------------------

    def log(self, seed: int, utilities: Iterable[float], start: int | None = None) -> None:
        """Log episode utilities of ``seed``: episodes ``start``, ``start + 1``, ... (by default after the last logged).

        Uploads a batch whenever the next values would not fit in one request body.

        Raises:
            ValueError: a seed that is not the run's, a value that is not finite, episodes past ``episodes``.
        """
        self._check_seed(seed)
        first = self._next.get(seed, 0) if start is None else int(start)
        texts = _floats(utilities, f"seed {seed}", first)
        if first < 0 or first + len(texts) > self.episodes:
            raise ValueError(f"seed {seed}: episodes {first}-{first + len(texts) - 1} are outside the run's "
                             f"{self.episodes} episodes (0-{self.episodes - 1})")
        head = f'{{"seed":{int(seed)},"start":'
        done = 0
        while done < len(texts):
            overhead = len(head) + 20 + 2
            room = self.batch_bytes - self._size - overhead
            take, used = 0, 0
            for text in texts[done:done + self.max_piece_values]:
                if used + len(text) + 1 > room:
                    break
                used += len(text) + 1
                take += 1
            if take == 0 or len(self._entries) + len(self._weights) >= self.max_entries:
                if not self._entries and not self._weights:
                    raise ValueError(f"a batch of {self.batch_bytes} bytes cannot hold one value")
                self.flush()
                continue
            entry = f'{head}{first + done},"values":[{",".join(texts[done:done + take])}]}}'
            self._entries.append(entry)
            self._size += len(entry) + 1
            done += take
        self._next[seed] = max(self._next.get(seed, 0), first + len(texts))
        if self._next[seed] == self.episodes and seed in self._held:
            self._queue_weights(self._held.pop(seed))

    def log_weights(self, seed: int, weights: Sequence[Sequence[float]]) -> None:
        """Log ``seed``'s final weights: one row per child (``n_children``), one value per type (``n_types``), >= 0.

        Sent once every episode of the seed has been logged (the service takes them only then).
        """
        self._check_seed(seed)
        rows = [list(row) for row in weights]
        children, types = self.weights_shape
        if len(rows) != children or any(len(row) != types for row in rows):
            raise ValueError(f"seed {seed}: weights must be {children} rows (one per child) of {types} values")
        texts = [f"[{','.join(_floats(row, f'weights of seed {seed}, child {c}'))}]" for c, row in enumerate(rows)]
        if any(float(v) < 0 for row in rows for v in row):
            raise ValueError(f"seed {seed}: weights must be >= 0")
        entry = f'{{"seed":{int(seed)},"weights":[{",".join(texts)}]}}'
        if self._next.get(seed, 0) == self.episodes:
            self._queue_weights(entry)
        else:
            self._held[seed] = entry

    def _queue_weights(self, entry: str) -> None:
        full = len(self._entries) + len(self._weights) >= self.max_entries
        if full or self._size + len(entry) + 1 > self.batch_bytes:
            self.flush()
        self._weights.append(entry)
        self._size += len(entry) + 1

    def _check_seed(self, seed: int) -> None:
        if seed not in self._seed_set:
            raise ValueError(f"seed {seed} is not one of the run's {len(self.seeds)} seeds")

    # ---- uploading --------------------------------------------------------------------------

    def flush(self) -> dict[str, Any] | None:
        """Upload what is buffered as one batch (none if nothing is); the service's answer."""
        if not self._entries and not self._weights:
            return None
        content = f'"utilities":[{",".join(self._entries)}],"weights":[{",".join(self._weights)}]'
        key = hashlib.sha256(f"{self.id}:{content}".encode()).hexdigest()[:40]
        body = f'{{"key":"{key}",{content}}}'.encode()
        _, answer = self.client.request("POST", f"/api/external-runs/{self.id}/batches", body)
        self._entries, self._weights, self._size = [], [], 0
        self.batches += 1
        self.replayed += bool(answer.get("replayed"))
        return answer

    def close(self) -> dict[str, Any]:
        """Upload what is buffered and close the run (every seed must be complete); the run's final state.

        Raises:
            ApiError: 409 naming the seeds that lack episodes (or weights, when some seeds have them).
        """
        if self._held:
            missing = ", ".join(str(s) for s in sorted(self._held)[:5])
            raise ValueError(f"weights were logged for seeds whose episodes are not all logged: {missing}")
        self.flush()
        _, self.state = self.client.request("POST", f"/api/external-runs/{self.id}/close", b"")
        return self.state

    def refresh(self) -> dict[str, Any]:
        """The run's state as the service has it now (``GET /api/external-runs/{id}``)."""
        _, self.state = self.client.request("GET", f"/api/external-runs/{self.id}")
        return self.state

    def __enter__(self) -> LoggedRun:
        return self

    def __exit__(self, kind: type[BaseException] | None, *_: Any) -> None:
        if kind is None:
            self.close()
        else:
            self.flush()
