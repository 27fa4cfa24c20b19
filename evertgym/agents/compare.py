"""Are two trained policies the same policy?  Compares their weights and normaliser (``evertgym compare-runs``).

    evertgym compare-runs agents/ubend_ppo_operator runs/ubend_ppo_operator_seed0
    evertgym compare-runs agents/colon_ppo_operator runs/colon_ppo_operator_seed0/checkpoints/model_80000_steps.zip

Each argument is a run folder (or a shipped policy's folder) holding ``final.zip`` and
``final_vecnormalize.pkl``, or a checkpoint ``model_<N>_steps.zip`` whose normaliser
``model_vecnormalize_<N>_steps.pkl`` lies beside it.  The policy weights (``policy.pth``
inside the SB3 zip) are read with ``torch.load(weights_only=True)``, which loads tensors and
never runs pickled code; the VecNormalize file is a plain pickle and is therefore compared by
its bytes (``evertgym.agents.trust.sha256_of``), never loaded.  The zip files themselves
differ between two identical trainings (SB3 stores the start time, the TensorBoard path, the
episodes' wall-clock times and pickled class descriptions), so their hashes prove nothing
either way.  Exit status 0 when the weights and the normaliser are identical, 1 otherwise,
2 when a model file is missing.
"""

from __future__ import annotations

import io
import sys
import zipfile
from pathlib import Path

from evertgym._extras import require
from evertgym.agents.trust import sha256_of


def model_files(arg: str) -> tuple[Path, Path]:
    """(model zip, VecNormalize file) of a run folder or of a checkpoint zip."""
    p = Path(arg)
    if p.suffix == ".zip":
        return p, p.with_name(p.name.replace("model_", "model_vecnormalize_", 1).replace(".zip", ".pkl"))
    return p / "final.zip", p / "final_vecnormalize.pkl"


def weights(model_zip: Path) -> dict:
    """The policy's tensors from an SB3 zip (tensors only: no code runs)."""
    require("evertgym compare-runs", "torch")
    import torch

    with zipfile.ZipFile(model_zip) as z:
        return torch.load(io.BytesIO(z.read("policy.pth")), map_location="cpu", weights_only=True)


def main(a: str, b: str) -> int:
    (za, na), (zb, nb) = model_files(a), model_files(b)
    for arg, z in ((a, za), (b, zb)):
        if not z.is_file():
            print(f"evertgym: error: run = {arg!r} has no model file {str(z)!r}", file=sys.stderr)
            return 2
    wa, wb = weights(za), weights(zb)
    if wa.keys() != wb.keys():
        print(f"different architectures: {sorted(wa)} vs {sorted(wb)}")
        return 1
    diff = max(float((wa[k].double() - wb[k].double()).abs().max()) if wa[k].shape == wb[k].shape else float("inf") for k in wa)
    numbers = sum(int(t.numel()) for t in wa.values())
    da, db = (sha256_of(p) if p.is_file() else None for p in (na, nb))  # a run without VecNormalize has none
    same_norm = da == db
    print(f"policy weights: {len(wa)} tensors, {numbers} numbers, largest difference {diff:.3g}"
          f" ({'identical' if diff == 0 else 'different'})")
    print(f"VecNormalize statistics: {'identical bytes' if same_norm else 'different'}")
    return 0 if diff == 0 and same_norm else 1


if __name__ == "__main__":
    if len(sys.argv) != 3:
        raise SystemExit(__doc__)
    sys.exit(main(sys.argv[1], sys.argv[2]))
