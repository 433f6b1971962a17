"""Tests of the benchmark scripts' options (benchmarks/)."""
