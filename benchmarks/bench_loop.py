"""The closed loop's cost: each scenario's real-time factor beside the plant alone's, in one run.

    PYTHONPATH=. .venv/bin/python benchmarks/bench_loop.py [--rounds 3] [--baseline COMMIT]
        [--scenarios walk_then_interact:15 walk:6 reach:4]
    PYTHONPATH=. .venv/bin/python benchmarks/bench_loop.py --per-step

For each ``SCENARIO:SECONDS``, one round runs, each in a fresh interpreter and one after the
other (so that all see the same machine load): the humanoid's plant alone on constant PD set
points for the same simulated time (the same robot, 1 ms SAP step and collision shapes; no
controller, ``bench_sot.plant_alone_realtime``), the scenario from this tree, and, with
``--baseline``, the scenario from the tree of that commit (``git archive`` into a temporary
directory). Only ``Simulator.AdvanceTo`` is timed (``drake_sot.diagrams.run.simulate``), not
the diagram's construction, in wall time and in the process's CPU time (the CPU time is the
steadier figure on a shared machine). The table gives per-round ratios
``scenario RTF / plant-alone RTF`` (the controller's share of the loop is ``1 - ratio`` when
the plant costs the same in both), their median and spread.

The **floor** row bounds from above what any controller made of Python ``LeafSystem``s can
reach on this Drake: the plant alone again, plus as many Python systems as the scenario has,
which make as many Python callbacks per control tick as the scenario's systems do (counted
once per scenario: calls of the package's functions made by Drake, from ``AdvanceTo`` or a
port's ``Eval``/``HasValue``, followed with ``sys.setprofile``), each an empty periodic publish at the control
period, on the package's base ``SotLeafSystem`` as the scenario's systems are. No port is
evaluated, nothing is computed, and the robot stands still on its PD set points: the scenario's
systems do all of that work and more, so its ratio cannot exceed the floor's (the plant in a
walking scenario costs more than standing, too). Each round's floor ratio is the median of 5
pairs (the plant alone, then with the empty systems, 3 s each) timed one after the other in one
interpreter: steadier than ratios between interpreters on a shared machine.

Each scenario row also gives its ticks' wall times (p50, p99, max, in ms; a tick is one control
period: the controllers' update and the physics steps to the next one, what a robot at 200 Hz
feels as jitter), and the **numerics free** row runs this tree's scenario with the pure modules'
results replayed from a recorded run (``numerics_free.py``): the same systems, ports and plant,
with the kernels free, so that each ratio can be read against the shape's ceiling.

``--per-step`` times what a Python system costs per physics step while doing nothing: after
every unrestricted update (the plant's step, with sampled output ports) Drake's simulator asks
every system for its witness functions again, a Python lookup for a system on pydrake's
``LeafSystem``, none on the package's ``SotLeafSystem`` where its marker is set (drake 1.51;
``drake_sot.systems.leaf`` says why).
"""

from __future__ import annotations

import argparse
import json
import os
import pathlib
import statistics
import subprocess
import sys
import tempfile
import time

from baseline_tree import extract

ROOT = pathlib.Path(__file__).resolve().parent.parent
DEFAULT_SCENARIOS = ("walk_then_interact:15", "walk:6", "reach:4")


def _measure(kind: str, scenario: str, duration: float) -> dict[str, float]:
    """Run in the child interpreter: time ``duration`` [s] of ``scenario`` (kind "scenario")
    or of the plant alone (kind "plant"); wall and CPU real-time factors."""
    import importlib

    import numpy as np

    def clocks() -> np.ndarray:
        return np.array([time.perf_counter(), time.process_time()])

    if kind in ("plant", "floor"):
        sys.path.insert(0, str(ROOT / "benchmarks"))
        from bench_sot import plant_alone_realtime

        if kind == "plant":
            wall, cpu = plant_alone_realtime(duration, clock=clocks)
            return {"wall": float(wall), "cpu": float(cpu)}
        # The floor beside the plant alone, alternately in this interpreter: FLOOR_PAIRS pairs.
        add = _floor_systems(**json.loads(scenario))
        floors, ratios = [], []
        for _ in range(FLOOR_PAIRS):
            plant = plant_alone_realtime(duration, clock=clocks)
            floor = plant_alone_realtime(duration, clock=clocks, add_systems=add)
            floors.append(floor)
            ratios.append(floor / plant)
        wall, cpu = np.median(floors, axis=0)
        ratio_wall, ratio_cpu = np.median(ratios, axis=0)
        return {
            "wall": float(wall),
            "cpu": float(cpu),
            "ratio_wall": float(ratio_wall),
            "ratio_cpu": float(ratio_cpu),
        }
    from drake_sot.diagrams.run import simulate

    def build():
        return importlib.import_module(f"drake_sot.diagrams.{scenario}").build(None)

    if kind == "count":
        return _count_callbacks(build(), duration)
    replay = None
    if kind == "free":  # record the pure functions' results in a first run, replay them in the timed one
        from numerics_free import Recording

        replay = Recording()
        with replay.recording():
            recorded = _run_ticks(build(), duration, simulate, clocks)
    if replay is None:
        timed = _run_ticks(build(), duration, simulate, clocks)
        del timed["q"]
        return timed
    with replay.replaying():  # built inside too: the calls of the build are replayed in order
        timed = _run_ticks(build(), duration, simulate, clocks)
    timed["replayed_calls"] = replay.replayed
    timed["drift"] = float(np.abs(np.asarray(timed.pop("q")) - np.asarray(recorded["q"])).max())
    return timed


def _run_ticks(setup, duration: float, simulate, clocks) -> dict:
    """Simulate ``setup`` for ``duration`` [s] one control period at a time: the real-time factors
    (wall, CPU), each tick's wall time [s] as p50, p99 and max (a tick is one control period: the
    controllers' update and the physics steps until the next), and the final positions ``q``."""
    import numpy as np

    simulator = setup.built.create_simulator()
    period = min(
        a.period_sec()
        for a in (
            s.GetUniquePeriodicDiscreteUpdateAttribute() for s in _python_leaves(simulator.get_system())
        )
        if a is not None
    )
    stamps = [time.perf_counter()]

    def tick(*_):
        stamps.append(time.perf_counter())

    t0 = clocks()
    result = simulate(simulator, duration, setup.commands, chunk=period, progress=tick)
    if not result.completed:
        raise SystemExit(f"the scenario failed: {result.failure}")
    wall, cpu = clocks() - t0
    ticks = np.diff(stamps)
    plant = setup.built.plant
    q = plant.GetPositions(plant.GetMyContextFromRoot(simulator.get_context()))
    return {
        "wall": duration / wall,
        "cpu": duration / cpu,
        "p50": float(np.percentile(ticks, 50)),
        "p99": float(np.percentile(ticks, 99)),
        "max": float(ticks.max()),
        "q": q.tolist(),
    }


def _python_leaves(diagram) -> list:
    """The package's ``LeafSystem``s in ``diagram``, subdiagrams included."""
    leaves = []
    for system in diagram.GetSystems():
        if hasattr(system, "GetSystems"):
            leaves += _python_leaves(system)
        elif type(system).__module__.startswith("drake_sot"):
            leaves.append(system)
    return leaves


def _count_callbacks(setup, duration: float) -> dict[str, float]:
    """The scenario's Python systems, its control period [s] (the shortest period of their
    periodic discrete updates) and the Python callbacks Drake makes per control tick, over
    ``duration``: calls of the package's functions made directly from inside a pydrake function
    (``AdvanceTo``, a port's ``Eval`` or ``HasValue``), followed with ``sys.setprofile``. Drake
    1.58's pybind11 functions (Python 3.12, 3.13) emit no profile event: there it exits, saying so,
    rather than count none."""
    from drake_sot.diagrams.run import simulate

    simulator = setup.built.create_simulator()
    leaves = _python_leaves(simulator.get_system())
    attributes = [system.GetUniquePeriodicDiscreteUpdateAttribute() for system in leaves]
    period = min(a.period_sec() for a in attributes if a is not None)
    calls = pydrake_calls = 0
    inside: list[bool] = []  # innermost last: True for a pydrake function, False for another

    def follow(frame, event: str, arg) -> None:
        nonlocal calls, pydrake_calls
        if event == "c_call":
            inside.append((getattr(arg, "__module__", None) or "").startswith("pydrake"))
            pydrake_calls += inside[-1]
        elif event == "call":
            calls += bool(inside and inside[-1] and "drake_sot" in frame.f_code.co_filename)
            inside.append(False)
        elif inside and event in ("c_return", "c_exception", "return"):
            inside.pop()

    sys.setprofile(follow)
    try:
        simulate(simulator, duration, setup.commands)
    finally:
        sys.setprofile(None)
    if not pydrake_calls:
        raise SystemExit(
            "bench_loop: this pydrake's functions emit no profile events (drake 1.58's pybind11): "
            "the callbacks cannot be counted here; run the floor on Python 3.11 (drake 1.51)"
        )
    return {"systems": len(leaves), "callbacks": round(calls * period / duration), "period": period}


def _floor_systems(systems: int, callbacks: int, period: float):
    """``add_systems`` for :func:`bench_sot.plant_alone_realtime`: ``systems`` Python systems
    (the package's base, ``SotLeafSystem``) making ``callbacks`` empty periodic publishes in all
    every ``period`` [s]."""
    from pydrake.systems.framework import EventStatus

    from drake_sot.systems.leaf import SotLeafSystem

    class Empty(SotLeafSystem):
        def __init__(self, events: int) -> None:
            super().__init__()
            for _ in range(events):
                self.DeclarePeriodicPublishEvent(period, 0.0, self._nothing)

        def _nothing(self, context) -> EventStatus:
            return EventStatus.Succeeded()

    def add(builder) -> None:
        each, extra = divmod(callbacks, systems)
        for i in range(systems):
            builder.AddSystem(Empty(each + (i < extra)))

    return add


def _per_step_costs(
    systems: int = 30, seconds: float = 2.0, rounds: int = 5
) -> dict[tuple[str, int, str], float]:
    """CPU µs per 1 ms step of a C++ zero-order hold alone and beside ``systems`` empty Python
    systems (no port, no event) on pydrake's ``LeafSystem`` or on the package's
    ``SotLeafSystem``, the hold's step a periodic discrete update (a vector hold) or an
    unrestricted one (an abstract hold, as the discrete ``MultibodyPlant``'s step with sampled
    output ports): what being a Python system costs per physics step, doing nothing. Median of
    ``rounds`` runs of ``seconds`` simulated, the cases shuffled in each round."""
    import random

    import numpy as np
    from pydrake.common.value import Value
    from pydrake.systems.analysis import Simulator
    from pydrake.systems.framework import DiagramBuilder, LeafSystem
    from pydrake.systems.primitives import ConstantValueSource, ConstantVectorSource, ZeroOrderHold

    from drake_sot.systems.leaf import SotLeafSystem

    class Idle(LeafSystem):
        """A Python system with nothing: no port, no state, no event."""

    class SotIdle(SotLeafSystem):
        """The same on the package's base."""

    def run(step: str, n: int, base: type) -> float:
        builder = DiagramBuilder()
        if step == "unrestricted":
            source = builder.AddSystem(ConstantValueSource(Value[object](0)))
            hold = builder.AddSystem(ZeroOrderHold(1e-3, Value[object](0)))
        else:
            source = builder.AddSystem(ConstantVectorSource(np.zeros(3)))
            hold = builder.AddSystem(ZeroOrderHold(1e-3, 3))
        builder.Connect(source.get_output_port(), hold.get_input_port())
        for _ in range(n):
            builder.AddSystem(base())
        simulator = Simulator(builder.Build())
        simulator.Initialize()
        t0 = time.process_time()
        simulator.AdvanceTo(seconds)
        return (time.process_time() - t0) / (seconds * 1e3) * 1e6

    bases = {"LeafSystem": Idle, "SotLeafSystem": SotIdle}
    cases = [(step, n, base) for step in ("discrete", "unrestricted") for n in (0, systems) for base in bases]
    times: dict[tuple[str, int, str], list[float]] = {case: [] for case in cases}
    for _ in range(rounds):
        random.shuffle(cases)
        for step, n, base in cases:
            times[(step, n, base)].append(run(step, n, bases[base]))
    return {case: statistics.median(values) for case, values in times.items()}


def _child(tree: pathlib.Path, kind: str, scenario: str, duration: float) -> dict[str, float]:
    """One measurement in a fresh interpreter with ``tree`` first on the path."""
    env = dict(os.environ, PYTHONPATH=str(tree), OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1")
    out = subprocess.run(
        [sys.executable, __file__, "--child", kind, scenario, str(duration)],
        env=env,
        check=True,
        capture_output=True,
        text=True,
        cwd=tree,
    ).stdout
    return json.loads(out.strip().splitlines()[-1])


FLOOR = "floor: the plant alone + the scenario's Python systems, empty"
FLOOR_PAIRS = 5  # plant alone / floor pairs timed alternately in one interpreter, per round
FLOOR_SECONDS = 3.0  # [s] simulated by each: the plant stands still, its cost per second is steady


#: The row of the scenario with its pure numerics replayed from a recorded run (numerics_free.py).
FREE = "this tree, numerics free (the kernels' results replayed)"
#: Each tick's wall time: its median, 99th percentile and largest, per round (medians over rounds).
TICK_CELLS = ("p50", "p99", "max")


def _cells() -> dict[str, list[float]]:
    return {"wall": [], "cpu": [], "rtf": [], **{cell: [] for cell in TICK_CELLS}}


def _spread(values: list[float]) -> str:
    return f"{statistics.median(values):.3f} ({min(values):.3f}-{max(values):.3f})"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n", 1)[0])
    parser.add_argument("--rounds", type=int, default=3, help="rounds per scenario (default 3)")
    parser.add_argument("--baseline", metavar="COMMIT", help="also time the scenarios of this commit's tree")
    parser.add_argument(
        "--scenarios",
        nargs="+",
        default=list(DEFAULT_SCENARIOS),
        metavar="NAME:SECONDS",
        help=f"scenarios and simulated seconds (default {' '.join(DEFAULT_SCENARIOS)})",
    )
    parser.add_argument(
        "--per-step",
        action="store_true",
        help="only the cost of empty Python systems per physics step (discrete or unrestricted step)",
    )
    parser.add_argument("--child", nargs=3, metavar=("KIND", "SCENARIO", "SECONDS"), help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        kind, scenario, seconds = args.child
        print(json.dumps(_measure(kind, scenario, float(seconds))))
        return
    if args.per_step:
        print("| the 1 ms step | systems on | alone | beside 30 empty Python systems | per Python system |")
        print("|---|---|---|---|---|")
        costs = _per_step_costs()
        for step in ("discrete", "unrestricted"):
            for base in ("LeafSystem", "SotLeafSystem"):
                alone, beside = costs[(step, 0, base)], costs[(step, 30, base)]
                print(
                    f"| {step} update | {base} | {alone:.1f} µs | {beside:.1f} µs "
                    f"| {(beside - alone) / 30:.2f} µs |"
                )
        return
    if not args.rounds >= 1:
        parser.error(f"--rounds {args.rounds}: must be at least 1")
    with tempfile.TemporaryDirectory() as tmp:
        trees = {"this tree": ROOT}
        if args.baseline:
            trees[args.baseline] = extract(args.baseline, pathlib.Path(tmp))
        print(f"load average at start: {os.getloadavg()[0]:.1f}")
        print(
            "| scenario | tree | RTF wall (median) | ÷ plant alone, wall | ÷ plant alone, CPU "
            "| tick p50 [ms] | tick p99 [ms] | tick max [ms] |"
        )
        print("|---|---|---|---|---|---|---|---|")
        for item in args.scenarios:
            scenario, _, seconds = item.partition(":")
            duration = float(seconds or 4.0)
            rows = [*trees, FREE]
            ratios: dict[str, dict[str, list[float]]] = {name: _cells() for name in rows}
            plant_rtf = []
            drift, replayed = 0.0, 0
            try:
                count = _child(ROOT, "count", scenario, min(duration, 2.0))
                ratios[FLOOR] = _cells()
            except subprocess.CalledProcessError as failed:  # uncountable here: no floor row
                count = None
                print(failed.stderr.strip().splitlines()[-1])
            for _ in range(args.rounds):
                plant = _child(ROOT, "plant", scenario, duration)
                plant_rtf.append(plant["wall"])
                if count is not None:
                    floor = _child(ROOT, "floor", json.dumps(count), min(duration, FLOOR_SECONDS))
                    ratios[FLOOR]["rtf"].append(floor["wall"])
                    for clock in ("wall", "cpu"):
                        ratios[FLOOR][clock].append(floor[f"ratio_{clock}"])
                for name in rows:
                    kind, tree = ("free", ROOT) if name == FREE else ("scenario", trees[name])
                    run = _child(tree, kind, scenario, duration)
                    ratios[name]["rtf"].append(run["wall"])
                    for clock in ("wall", "cpu"):
                        ratios[name][clock].append(run[clock] / plant[clock])
                    for cell in TICK_CELLS:
                        ratios[name][cell].append(1e3 * run[cell])
                    if name == FREE:
                        drift = max(drift, run["drift"])
                        replayed = run["replayed_calls"]
            print(
                f"| {scenario} ({duration:g} s) | plant alone | {statistics.median(plant_rtf):.2f} | 1 | 1 "
                "| | | |"
            )
            if count is not None:
                print(
                    f"| {scenario} | (its {count['systems']} Python systems, {count['callbacks']} callbacks "
                    f"a tick of {1e3 * count['period']:g} ms) | | | | | | |"
                )
            for name, r in ratios.items():
                ticks = " | ".join(
                    f"{statistics.median(r[cell]):.2f}" if r[cell] else "" for cell in TICK_CELLS
                )
                print(
                    f"| {scenario} ({duration:g} s) | {name} | {statistics.median(r['rtf']):.2f} "
                    f"| {_spread(r['wall'])} | {_spread(r['cpu'])} | {ticks} |"
                )
            print(
                f"| {scenario} | ({FREE}: {replayed} calls replayed a run; final positions within "
                f"{drift:.1e} of the recorded run's) | | | | | | |"
            )
        print(f"load average at end: {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
