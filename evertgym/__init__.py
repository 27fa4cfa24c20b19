"""evertgym: simulation, band design and pressure control of soft growing robots.

Layers (each knows only those below it): ``evertgym.design`` < ``evertgym.model`` (Cosserat
rod, pressure and section laws) < ``evertgym.scenes`` < ``evertgym.sim`` (pymunk simulator)
< ``evertgym.env`` (Gymnasium) < ``evertgym.scoring`` (trial-agnostic runner) <
``evertgym.experiments`` / ``evertgym.agents`` < ``evertgym.bench`` < ``evertgym.cli``.

Importing the package registers the Gymnasium environments by entry-point string: it
imports Gymnasium and the presets' TOML files, not pymunk or scipy, until an env is made.
"""

from evertgym._version import __version__
from evertgym.env import register_envs

register_envs()

__all__ = ["__version__", "register_envs"]
