"""Type stubs of hjacc._native, the compiled half of hjacc (python/hjacc-native/src/lib.rs)."""

from os import PathLike
from typing import Any, Optional, Sequence, Tuple, Union

_Path = Union[str, "PathLike[str]"]

FORMAT_VERSION: int

class Table:
    """A safety table, checked whole when made; lookups by the Rust reader."""

    def __init__(self, data: bytes) -> None: ...
    @staticmethod
    def open(path: _Path) -> "Table": ...
    @property
    def header(self) -> dict[str, Any]: ...
    @property
    def error_bound(self) -> float: ...
    def value_at(self, state: Sequence[float]) -> float: ...
    def policy_at(self, state: Sequence[float]) -> str: ...
    def contains(self, state: Sequence[float]) -> bool: ...
    def node_value(self, node: int) -> float: ...
    def node_values(self) -> list[float]: ...
    def coordinates(self, k: int) -> list[float]: ...
    def __len__(self) -> int: ...

def run(config_path: _Path, out: _Path = "out") -> dict[str, Any]: ...
def run_rear(config_path: _Path, out: _Path = "out") -> dict[str, Any]: ...
def verify(
    table: _Path,
    out: _Path = "out",
    periods_ms: Sequence[float] = (20.0, 100.0, 200.0, 300.0),
    rear_margin: float = 0.0,
    depth: int = 21,
    budget_seconds: Optional[float] = 600.0,
    max_unproven: Optional[int] = 1000,
    exhaustive: bool = False,
    range_error: Optional[float] = None,
    range_error_relative: Optional[float] = None,
    range_rate_error: Optional[float] = None,
    ego_speed_error: Optional[float] = None,
    ego_speed_error_relative: Optional[float] = None,
    ego_age: Optional[float] = None,
) -> dict[str, Any]: ...
def campaign(
    episodes: int = 500,
    seconds: float = 120.0,
    seed: int = 1,
    sensors: str = "datasheet",
    latency: int = 0,
    cut_in: Optional[str] = None,
    dead_time_ms: float = 100.0,
    lag: float = 0.3,
    table: Optional[_Path] = None,
    out: _Path = "out/campaign",
) -> dict[str, Any]: ...
def falsify(
    episodes: int = 5000,
    seconds: float = 120.0,
    seed: int = 1,
    table: Optional[_Path] = None,
    out: _Path = "out/falsify",
) -> dict[str, Any]: ...
def sweep(path: _Path, out: _Path = "out") -> dict[str, Any]: ...
def sweep_tasks(path: _Path) -> Tuple[str, list[str]]: ...
def run_sweep_task(task: str, sweep_name: str, out: _Path) -> str: ...
def write_sweep_summary(
    path: _Path, results: Sequence[str], out: _Path = "out", seconds: float = 0.0
) -> dict[str, Any]: ...
