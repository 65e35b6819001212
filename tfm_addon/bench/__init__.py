"""Benchmarks: speed against accuracy, measured side by side in one run.

``python -m tfm_addon.bench`` (``--quick`` for the small version the tests run).
"""
