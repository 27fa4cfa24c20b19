"""The experiments layer: evertgym's own studies, run through the trial-agnostic scoring runner.

- :mod:`~evertgym.experiments.trial`: the physics trial (a design grows through a scene under a
  pressure policy), the trial function every scored experiment hands to
  :func:`evertgym.scoring.run_trials`;
- the paper's reproductions: :mod:`~evertgym.experiments.stiffness` (Exp 1-3),
  :mod:`~evertgym.experiments.eversion` (Exp 4), :mod:`~evertgym.experiments.paper` (the U-bend
  validation and the colon case study), and the fit of the model's free parameters,
  :mod:`~evertgym.experiments.calibration`;
- :mod:`~evertgym.experiments.sweep` and :mod:`~evertgym.experiments.optimize`: design sweeps and
  the band-design search; :mod:`~evertgym.experiments.jam` and :mod:`~evertgym.experiments.plots`:
  their tables and figures.

It sits beside ``evertgym.agents`` (whose policies a trial plays) and above ``evertgym.scoring``.
"""
