"""Moved: :func:`jam_anatomy` is :mod:`evertgym.sim.diagnostics`; the jam tables are
:mod:`evertgym.experiments.jam`.  This name is kept for scripts that import it from here."""

from evertgym.sim.diagnostics import jam_anatomy

__all__ = ["jam_anatomy"]
