"""Type stubs for the Rust extension ``batecho._core`` (see rust/src/bindings.rs).

Arrays are float64 NumPy arrays unless noted; lengths in metres, angles in radians.
"""

from os import PathLike

import numpy as np
import numpy.typing as npt

__version__: str

_F64 = npt.NDArray[np.float64]
_BeamTuple = tuple[float, float, float, float, float, float]  # (A1, sx, sy, theta, az0, el0)

class Scene:
    """Leaves (centres (n,3), unit normals (n,3), radii (n,)) and their BVH; branch segments
    (starts (k,3), ends (k,3), radii (k,)). Either may be empty, not both."""

    def __init__(
        self,
        centers: _F64,
        normals: _F64,
        radii: _F64,
        branch_starts: _F64 | None = None,
        branch_ends: _F64 | None = None,
        branch_radii: _F64 | None = None,
    ) -> None: ...
    @property
    def n_leaves(self) -> int: ...
    @property
    def n_branches(self) -> int: ...
    @property
    def build_time_s(self) -> float: ...
    @property
    def n_nodes(self) -> int: ...
    def clearance(self, points: _F64) -> tuple[_F64, npt.NDArray[np.int64]]: ...
    def min_clearance(self, points: _F64, upper: float) -> float: ...

class Sonar:
    """A validated sonar with its derived tables (see ``batecho.Sonar``)."""

    def __init__(
        self,
        emitter: _BeamTuple,
        receiver: _BeamTuple | None,
        lobe: str,
        threshold_db: float,
        r0: float,
        p0: float,
        p_ref: float,
        cone_half_angle: float | None,
        max_range: float | None,
        fs: float,
        n_samples: int,
        f_lo: float,
        f_hi: float,
        sound_speed: float,
        leaf_model: str,
        spreading: bool,
        gain: float,
        window: str,
        atmosphere: tuple[float, float, float] | None,
        min_range: float,
        too_close: str,
        min_ka: float,
        receivers: list[tuple[tuple[float, float, float], _BeamTuple | None]] | None = None,
        shading: tuple[float, bool] | None = None,
        branch_piece_scale: float = 1.0,
    ) -> None: ...
    @property
    def n_receivers(self) -> int: ...
    @property
    def freqs(self) -> _F64: ...
    @property
    def bins(self) -> tuple[int, int]: ...
    @property
    def range_limit(self) -> float: ...
    @property
    def max_reach(self) -> float: ...
    @property
    def absorption_db_per_m(self) -> _F64 | None: ...

def simulate_many(
    scenes: list[Scene],
    sonar: Sonar,
    positions: list[_F64],
    forward: list[_F64],
    up: list[_F64],
    left: list[_F64],
    search: str,
    method: str,
    tol: float,
) -> list[tuple[npt.NDArray[np.complex128], npt.NDArray[np.uint64]]]: ...
def simulate(
    scene: Scene,
    sonar: Sonar,
    positions: _F64,
    forward: _F64,
    up: _F64,
    left: _F64,
    impulse: bool = True,
    search: str = "bvh",
    method: str = "exact",
    tol: float = 1e-12,
) -> tuple[
    npt.NDArray[np.complex128],
    _F64 | None,
    npt.NDArray[np.uint64],
    npt.NDArray[np.complex128] | None,
    npt.NDArray[np.uint64],
    npt.NDArray[np.uint64],
]: ...
def lobe_members(
    scene: Scene,
    sonar: Sonar,
    position: _F64,
    forward: _F64,
    up: _F64,
    left: _F64,
    search: str = "bvh",
    receiver: int | None = None,
) -> npt.NDArray[np.int64]: ...
def leaf_sights(
    scene: Scene,
    sonar: Sonar,
    position: _F64,
    forward: _F64,
    up: _F64,
    left: _F64,
    branches_block: bool,
) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.uint64], npt.NDArray[np.bool_]]: ...
def farthest_members(
    scene: Scene, sonar: Sonar, positions: _F64, forward: _F64, up: _F64, left: _F64
) -> _F64: ...
def load_obj(
    path: str | PathLike[str],
    leaf_patterns: list[str] | None = None,
    per: str = "patch",
    up: str = "z",
    scale: float = 1.0,
    transform: _F64 | None = None,
) -> tuple[
    _F64,
    _F64,
    _F64,
    _F64,
    npt.NDArray[np.int64],
    _F64,
    npt.NDArray[np.int64],
    npt.NDArray[np.int64],
    list[str],
    int,
    list[str],
]: ...

class Airframe:
    """A quadrotor's parameters and SE(3) gains, checked (see ``batecho.Quadrotor``)."""

    def __init__(
        self,
        *,
        mass: float,
        inertia: _F64,
        arm_length: float,
        k_f: float,
        k_m: float,
        motor_time_constant: float,
        omega_min: float,
        omega_max: float,
        drag: _F64,
        configuration: str,
        gravity: float,
        k_x: _F64,
        k_v: _F64,
        k_R: _F64,
        k_Omega: _F64,
        drag_feedforward: bool,
    ) -> None: ...
    @property
    def mixer(self) -> _F64: ...

def fly(
    airframe: Airframe,
    y0: _F64,
    p: _F64,
    v: _F64,
    a: _F64,
    yaw: _F64,
    omega: _F64,
    domega: _F64,
    wind: _F64,
    times: _F64,
) -> _F64: ...

class Swarm:
    """Drones of one airframe stepped under velocity-and-yaw-rate commands."""

    def __init__(self, airframe: Airframe, states: _F64) -> None: ...
    def reset(self, states: _F64) -> None: ...
    @property
    def states(self) -> _F64: ...
    @property
    def n_drones(self) -> int: ...
    def step(
        self, velocities: _F64, yaw_rates: _F64, wind: _F64, dt: float, n_steps: int
    ) -> npt.NDArray[np.float64]: ...

def memory_limit() -> int: ...
def set_memory_limit(bytes: int) -> int: ...
