"""Support code shared by the test suites and the benchmarks (not tests themselves)."""
