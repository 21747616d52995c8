"""Gymnasium environments: ``batecho/EchoFlight-v0`` (:class:`EchoFlightEnv`), a quadrotor
that flies through a forest by the echoes it hears, registered on import of this package.

:class:`EchoFlightVectorEnv` steps N of them as one (``gymnasium.make_vec``'s default for
this id): one Rust call flies the drones, one sends the pulses.

Needs the ``env`` extra (``pip install "batecho[env]"``, Gymnasium). The baselines are in
:mod:`batecho.envs.baselines`.
"""

from __future__ import annotations

try:
    import gymnasium
except ImportError as e:  # pragma: no cover - the test extra installs gymnasium
    raise ImportError('batecho.envs needs Gymnasium: pip install "batecho[env]"') from e

from .echo_flight import EchoFlightEnv
from .vector import EchoFlightVectorEnv

__all__ = ["ENV_ID", "EchoFlightEnv", "EchoFlightVectorEnv"]

#: The id under which :class:`EchoFlightEnv` is registered.
ENV_ID = "batecho/EchoFlight-v0"

if ENV_ID not in gymnasium.registry:
    gymnasium.register(
        id=ENV_ID,
        entry_point="batecho.envs.echo_flight:EchoFlightEnv",
        vector_entry_point="batecho.envs.vector:EchoFlightVectorEnv",
    )
