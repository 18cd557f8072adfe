"""A small client of an MG-RAO service for runs logged from outside (docs/platform.md, "Logging runs").

Standard library only (``urllib``), so that any learner's environment can import it::

    from mgrao_client import Client

    client = Client("http://127.0.0.1:8000", token=None)
    run = client.open_run(label="my-learner", system="single", seeds=30, episodes=100, params={})
    for seed in range(30):
        for episode in range(100):
            ...
            run.log(seed, [utility])        # one episode, or many at once
        run.log_weights(seed, weights)      # optional: n_children rows of n_types values
    run.close()                             # every seed complete: the run appears in compare

``log`` buffers and uploads a batch whenever the next values would not fit in one request body (the
service's ``max_body_bytes``), each batch under a key derived from its content, retried on a lost
connection or a busy database: a batch the service already stored is answered as a replay and never
stored twice. Opened with a ``key``, a run that a crashed program opened is found again, so starting
the program over resumes the same run (the batches already stored are replays).
"""

from mgrao_client.client import ApiError, Client, LoggedRun, ServiceUnavailable

__all__ = ["ApiError", "Client", "LoggedRun", "ServiceUnavailable"]
