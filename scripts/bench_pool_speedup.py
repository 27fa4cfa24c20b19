#!/usr/bin/env python
"""Throughput of the scoring backends: serial, process pool (1 and 2 workers) and Dask (2 workers).

    python scripts/bench_pool_speedup.py [--trials 16] [--trial-s 0.3] [--real] [--no-dask] [--json]

Same as ``evertgym bench pool``; what each row means is in :mod:`evertgym.bench.pool`.
"""

import sys

from evertgym.cli import main

if __name__ == "__main__":
    sys.exit(main(["bench", "pool", *sys.argv[1:]]))
