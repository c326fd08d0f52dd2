"""Benchmarks of motes, each printing ratios against baselines measured in the same run.

Run from the repository root, e.g. ``python -m benchmarks.emitter`` (``--quick`` for a
seconds-long smoke run). See ``docs/performance.md`` for what each one measures.
"""
