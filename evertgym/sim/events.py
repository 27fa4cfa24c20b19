"""What a simulation reports as it runs: timed events (both engines)."""

from __future__ import annotations

from dataclasses import dataclass, field


@dataclass
class SimEvent:
    """One event: ``kind`` is ``band_at_tip``, ``contact``, ``kink``, ``stall`` or ``solve_failed``
    (the quasi-static engine's solve ended above its tolerance); times in s, insertion in mm."""

    t_s: float
    kind: str
    insertion_mm: float
    detail: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        return {"t_s": self.t_s, "event": self.kind, "insertion_mm": self.insertion_mm, **self.detail}
