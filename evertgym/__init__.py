"""evertgym: simulation, band design and pressure control of soft growing robots.

Layers (each knows only those below it): ``evertgym.model`` (Cosserat rod, pressure
law, calibration), ``evertgym.sim`` (pymunk simulator), ``evertgym.scenes``,
``evertgym.env`` (Gymnasium), ``evertgym.scoring`` and ``evertgym.agents``.
Importing the package registers the Gymnasium environments.
"""

__version__ = "0.2.0"


def _register() -> None:
    from evertgym.env import register_envs

    register_envs()


_register()
