"""Property tests draw the same examples on every run, so that a red build can be reproduced and a
green one means the same thing twice (Hypothesis, derandomized). `HYPOTHESIS_PROFILE=explore` draws
new examples each run, to look for cases the fixed ones miss."""

import os

from hypothesis import settings

settings.register_profile("fixed", derandomize=True)
settings.register_profile("explore", derandomize=False)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "fixed"))
