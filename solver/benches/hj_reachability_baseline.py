"""hj_reachability on the solver benchmark's problem (the paper's 4-D baseline), for a side-by-side
run with `cargo bench -p solver --bench solve`. Prints a row per grid: steps, median solve time
(compile measured apart, by a warm-up call with the same shapes), share of nodes with V > 1 mm.
Usage: python hj_reachability_baseline.py 21 31 [--repeat 3]"""
import sys
import time

import jax.numpy as jnp
import numpy as np
import hj_reachability as hj


class Baseline(hj.ControlAndDisturbanceAffineDynamics):
    def __init__(self):
        super().__init__(
            control_mode="max",
            disturbance_mode="min",
            control_space=hj.sets.Box(jnp.array([-2.0]), jnp.array([2.0])),
            disturbance_space=hj.sets.Box(jnp.array([-1.5, -1.5]), jnp.array([1.5, 1.5])),
        )

    def open_loop_dynamics(self, state, time):
        return jnp.array([state[1], 0.0, state[3], 0.0])

    def control_jacobian(self, state, time):
        return jnp.array([[0.0], [-1.0], [0.0], [1.0]])

    def disturbance_jacobian(self, state, time):
        return jnp.array([[0.0, 0.0], [1.0, 0.0], [0.0, 0.0], [0.0, -1.0]])


def main():
    args = [a for a in sys.argv[1:]]
    repeat = 3
    if "--repeat" in args:
        i = args.index("--repeat")
        repeat = int(args[i + 1])
        del args[i : i + 2]
    grids = [int(a) for a in args] or [21, 31]
    settings = hj.SolverSettings.with_accuracy(
        "very_high", hamiltonian_postprocessor=hj.solver.backwards_reachable_tube, CFL_number=0.75
    )
    print("| grid | solve median (s) | runs (s) | compile (s) | share V > 1 mm |")
    print("|---|---|---|---|---|")
    for n in grids:
        grid = hj.Grid.from_lattice_parameters_and_boundary_conditions(
            hj.sets.Box(np.array([-5.0, -10.0, -5.0, -10.0]), np.array([45.0, 10.0, 45.0, 10.0])),
            (n, n, n, n),
        )
        l = jnp.minimum(grid.states[..., 0], grid.states[..., 2])
        dyn = Baseline()
        t0 = time.perf_counter()
        hj.step(settings, dyn, grid, 0.0, l, -0.1, progress_bar=False).block_until_ready()
        compile_s = time.perf_counter() - t0
        runs = []
        for _ in range(repeat):
            t0 = time.perf_counter()
            v = hj.step(settings, dyn, grid, 0.0, l, -3.0, progress_bar=False).block_until_ready()
            runs.append(time.perf_counter() - t0)
        share = float(jnp.mean(v > 1e-3))
        print(f"| {n}^4 | {sorted(runs)[len(runs) // 2]:.2f} | {' '.join(f'{r:.2f}' for r in runs)} | {compile_s:.1f} | {share:.3f} |")


if __name__ == "__main__":
    main()
