#!/usr/bin/env python
"""Calibrate the rod model on the paper's calibrate_on rows and rewrite the parameter file.

    python scripts/calibrate_model.py            # fits, prints every candidate, writes
                                                 # evertgym/data/model_params.json
    python scripts/calibrate_model.py --dry-run  # fits and prints, writes nothing
    python scripts/calibrate_model.py --part eversion   # refit only the eversion
                                                 # threshold section (seconds)

Only Exp 1 and Exp 3 (marked calibrate_on in measurements.json) enter the fit; Exp 2 is
printed as a prediction.  See evertgym/model/calibration.py for the candidate structures.
"""

import argparse
import json
import sys

from evertgym.experiments.calibration import calibrate, write_params
from evertgym.model.eversion import fit_eversion_threshold
from evertgym.model.params import PARAMS_PATH


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--dry-run", action="store_true", help="print the result, do not write the parameter file")
    ap.add_argument("--part", choices=["all", "eversion"], default="all", help="what to refit (default: all)")
    args = ap.parse_args()
    if args.part == "eversion":
        result = json.loads(PARAMS_PATH.read_text())
        result["eversion_threshold"] = fit_eversion_threshold()
        print(json.dumps(result["eversion_threshold"], indent=2))
    else:
        result = calibrate(progress=lambda s: print(s, flush=True))
    if args.dry_run:
        json.dump(result, sys.stdout, indent=2)
        print()
    else:
        write_params(result)
        print("wrote evertgym/data/model_params.json")
    return 0


if __name__ == "__main__":
    sys.exit(main())
