"""What the replay costs the closed loop: a scenario without Meshcat, drawn live, and recorded.

    PYTHONPATH=. .venv/bin/python benchmarks/bench_replay.py [--scenario walk_then_interact]
        [--seconds 6] [--rounds 4]

Each round simulates the scenario three times in this one interpreter, one after the other (so
that the three see the same machine load), each from a fresh build:

- ``none``: no Meshcat (``drake-sot run --no-record``): no visualizer, no replay systems;
- ``live``: a headless Meshcat (``loopback_meshcat``) with what a run draws — the visualizer at
  30 Hz, the force arrows with the soles' contact forces (logged at every control tick), the
  camera that follows the pelvis, the self-collision pairs — not recording (what ``serve``
  without ``--out`` draws);
- ``recorded``: the same, recording the replay (``drake-sot run``'s default).

Only ``simulate`` is timed, in the process's CPU time (every thread: Meshcat's server thread
too), not the build nor the replay's writing. The table gives each variant's median CPU time
and the median over the rounds of its ratio to ``none`` in the same round.
"""

from __future__ import annotations

import argparse
import statistics
import time

VARIANTS = ("none", "live", "recorded")


def simulate_once(scenario: str, seconds: float, variant: str, meshcat) -> float:
    """CPU time [s] of ``seconds`` of ``scenario`` simulated as ``variant`` (see the module
    docstring), drawing into ``meshcat`` unless ``none``; the drawing is deleted after."""
    from drake_sot.diagrams import SCENARIOS
    from drake_sot.diagrams.run import simulate
    from drake_sot.diagrams.scenario import build_scenario

    setup = build_scenario(SCENARIOS[scenario], None if variant == "none" else meshcat)
    simulator = setup.built.create_simulator()
    visualizer = setup.built.visualizer
    if variant == "recorded":
        visualizer.StartRecording(set_transforms_while_recording=True)
    start = time.process_time()
    simulate(simulator, seconds, setup.commands, check=False)
    cpu = time.process_time() - start
    if visualizer is not None:
        visualizer.DeleteRecording()
        meshcat.Delete()
    return cpu


def main() -> None:
    from drake_sot.blas import limit_blas_threads
    from drake_sot.diagrams.world import loopback_meshcat

    limit_blas_threads(1)  # as the front-ends do when they start a run (drake_sot.blas)
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenario", default="walk_then_interact")
    parser.add_argument("--seconds", type=float, default=6.0, help="simulated per run (default 6)")
    parser.add_argument("--rounds", type=int, default=4, help="rounds of the three variants (default 4)")
    args = parser.parse_args()
    meshcat = loopback_meshcat()
    cpu: dict[str, list[float]] = {v: [] for v in VARIANTS}
    for k in range(args.rounds):
        for variant in VARIANTS:
            cpu[variant].append(simulate_once(args.scenario, args.seconds, variant, meshcat))
        print(f"round {k + 1}: " + ", ".join(f"{v} {cpu[v][-1]:.2f} s" for v in VARIANTS), flush=True)
    print(f"\n{args.scenario}, {args.seconds:g} s simulated, {args.rounds} rounds (CPU time of simulate):\n")
    print("| variant | CPU time (median) | ÷ none, same round (median; spread) |")
    print("|---|---|---|")
    for variant in VARIANTS:
        ratios = [a / b for a, b in zip(cpu[variant], cpu["none"], strict=True)]
        print(
            f"| {variant} | {statistics.median(cpu[variant]):.2f} s | {statistics.median(ratios):.3f} "
            f"({min(ratios):.3f}-{max(ratios):.3f}) |"
        )


if __name__ == "__main__":
    main()
