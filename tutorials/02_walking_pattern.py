# %% [markdown]
# # Tutorial 02 — a walking pattern: footsteps, their ZMP reference, the CoM that realises it
#
# A humanoid walks without falling when the zero-moment point (ZMP) stays inside the
# support polygon of the feet on the ground. Kajita et al. 2003 plan a walk in three
# moves, and drake_sot keeps them as pure functions you can run before any simulation:
#
# 1. **footsteps** (`drake_sot.footsteps`): where each foot lands, checked against the
#    reachability of a step;
# 2. **the ZMP reference** they imply: on the stance foot in single support, moving from
#    one foot to the other in double support (`FootstepPlan.sample`);
# 3. **the CoM** that makes the cart-table model's ZMP follow that reference: ZMP
#    preview control (`drake_sot.preview.PreviewController.plan`), which looks ahead at
#    the next samples of the reference, so that the CoM starts moving *before* the ZMP
#    has to.
#
# Then the same walk runs online in the `PatternGenerator` system (the SoT's `pg`
# entity), driven by the paper's `:stepseq` command; it gives the same CoM. The walking
# scenario (`drake-sot run walk`) feeds these references to the whole-body controller of
# a simulated humanoid. Run this file with `python tutorials/02_walking_pattern.py`, or
# open it as a notebook (`# %%` cells); it takes a few seconds.

# %%
import math
import os
from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # write the figure to a file, open no window
import matplotlib.pyplot as plt
import numpy as np
from pydrake.systems.analysis import Simulator

from drake_sot.footsteps import WALKING_BOUNDS, Footstep, StepTiming, alternating_steps, stance_width
from drake_sot.models.humanoid import SOLE
from drake_sot.preview import PreviewController
from drake_sot.support import signed_distance_inside, sole_corners, support_polygon
from drake_sot.systems.pattern_generator import PatternGenerator
from drake_sot.walk_planner import FootstepPlan

OUT = Path(os.environ.get("DRAKE_SOT_OUT", "out"))
OUT.mkdir(parents=True, exist_ok=True)
DT = 0.005  # [s] the control period (HRP-2's 5 ms)
Z_C = 0.814  # [m] CoM height of the cart-table model

# %% [markdown]
# ## 1. Footsteps
#
# The robot stands with its soles 0.19 m apart. As in the original pattern generator's
# `:stepseq`, a step is given relative to the **other** foot's last footprint: "0.2 m
# ahead of it, 0.19 m to its side, turned by 0.1 rad". `alternating_steps` makes such
# steps with alternating feet: 5 steps forward, then 4 turning left (the left foot opens
# first, so the feet never cross) and a closing step that puts the feet side by side.
# `FootstepPlan` checks every step against `StepLimits` (stride, width, yaw); a step
# out of reach is refused with the limit's name.

# %%
left, right = Footstep(0.0, 0.095, 0.0, "left"), Footstep(0.0, -0.095, 0.0, "right")
timing = StepTiming(single_support=0.7, double_support=0.1, step_height=0.05)
forward = alternating_steps(left, right, 5, stride=0.2, first_side="right")
last = {s.side: s for s in [left, right, *forward]}
turning = alternating_steps(
    last["left"], last["right"], 5, stride=0.05, turn=[math.pi / 10] * 4 + [0.0], first_side="left"
)
steps = forward + turning
plan = FootstepPlan(left, right, steps, timing=timing)
print(f"{len(plan)} steps, stance width {stance_width(left, right):.3f} m")
for step in steps:
    print(f"  {step.side:5s} foot to x = {step.x:+.3f} m, y = {step.y:+.3f} m, yaw = {step.yaw:+.3f} rad")
try:
    FootstepPlan(left, right, [Footstep(0.6, -0.095, 0.0, "right")])
except ValueError as refused:
    print(f"refused: {refused}")

# %% [markdown]
# ## 2. The ZMP reference
#
# `plan.sample(dt, hold, stand)` samples the walk every `dt`: first `stand` seconds
# standing (a lead-in: a CoM at rest cannot anticipate a ZMP transfer that it has not
# seen yet, so give it about one preview time), then per step a double support where the
# ZMP reference moves onto the stance foot and a single support where it stays there
# while the other foot swings (a quintic in x, y and yaw, a bump of `step_height` in z),
# then the ZMP goes back between the feet and stays there `hold` seconds. The result is
# a `Segment`: the ZMP reference, both sole trajectories and the contact phase, per sample.

# %%
walk = plan.sample(DT, hold=1.0, stand=1.6)
t = DT * np.arange(len(walk))
swing_top = max(walk.left[:, 2].max(), walk.right[:, 2].max())
print(f"{len(walk)} samples ({t[-1]:.2f} s); highest swing-foot point {swing_top:.3f} m")

# %% [markdown]
# ## 3. The CoM: ZMP preview control, offline
#
# The cart-table model puts the CoM at a constant height `z_c`; its ZMP is
# `p = c - z_c/g · c̈`. `PreviewController(dt, z_c, horizon)` computes Katayama's optimal
# preview gains once (a discrete Riccati equation); `plan(zmp_reference)` then runs the
# controller over the whole reference and returns, per sample, the CoM position,
# velocity and acceleration and the model's ZMP. How long it previews matters: with a
# preview shorter than a step, the CoM starts late and the model ZMP strays centimetres
# from its reference, towards the edge of the support polygon (the pattern generator
# refuses a preview time under 1 s). We measure the model ZMP's margin inside the polygon
# of the soles in contact.

# %%


def margins(segment, zmp: np.ndarray) -> np.ndarray:
    """Signed distance [m] of each ZMP sample inside the support polygon (negative: outside)."""
    out = np.empty(len(segment))
    for k, phase in enumerate(segment.phase):
        feet = [f for f, down in (("left", phase != 2), ("right", phase != 1)) if down]
        soles = [sole_corners(*getattr(segment, f)[k][[0, 1, 3]], SOLE) for f in feet]
        out[k] = signed_distance_inside(support_polygon(soles), zmp[k])
    return out


reference_margin = margins(walk, walk.zmp).min()
results = {}
for horizon in (0.5, 1.0, 1.6):
    com_plan = PreviewController(dt=DT, z_c=Z_C, horizon=horizon).plan(walk.zmp)
    results[horizon] = com_plan
    print(
        f"preview {horizon:.1f} s: ZMP tracking error {np.abs(com_plan.zmp - walk.zmp).max() * 100:.1f} cm, "
        f"least margin in the support polygon {margins(walk, com_plan.zmp).min() * 100:+.1f} cm"
    )
com = results[1.6]
print(f"least margin of the ZMP reference itself: {reference_margin * 100:+.1f} cm")
swing = {name: np.ptp(y[:, 1]) for name, y in (("ZMP", walk.zmp), ("CoM", com.com))}
print(f"lateral swing peak to peak: ZMP reference {swing['ZMP']:.3f} m, CoM {swing['CoM']:.3f} m")
# The claims of this tutorial, checked: the reference and the 1.6 s plan stay inside the
# support polygon, the 0.5 s plan tracks several times worse and comes closer to its
# edge, and the CoM swings less than the ZMP (the inverted pendulum smooths).
assert reference_margin > 0.0 and margins(walk, com.zmp).min() > 0.0
short_error, long_error = (np.abs(results[h].zmp - walk.zmp).max() for h in (0.5, 1.6))
assert short_error > 5 * long_error
assert margins(walk, results[0.5].zmp).min() < margins(walk, com.zmp).min()
assert swing["CoM"] < swing["ZMP"]

# %% [markdown]
# The figure: footprints, the ZMP reference and the planned CoM seen from above, and
# the lateral ZMP and CoM against time — the CoM swings less than the ZMP and turns
# before it.

# %%
fig, (top, side) = plt.subplots(1, 2, figsize=(13, 5))
for step in [left, right, *steps]:
    corners = sole_corners(step.x, step.y, step.yaw, SOLE)
    top.fill(corners[:, 0], corners[:, 1], alpha=0.25, color="tab:blue" if step.side == "left" else "tab:red")
top.plot(walk.zmp[:, 0], walk.zmp[:, 1], "k-", lw=1, label="ZMP reference")
top.plot(com.com[:, 0], com.com[:, 1], "g-", lw=2, label="CoM (preview 1.6 s)")
top.plot(results[0.5].zmp[:, 0], results[0.5].zmp[:, 1], "m:", lw=1, label="model ZMP, preview 0.5 s")
top.set(xlabel="x [m]", ylabel="y [m]", title="footprints seen from above")
top.axis("equal")
top.legend(loc="upper left")
side.plot(t, walk.zmp[:, 1], "k-", lw=1, label="ZMP reference y")
side.plot(t, com.zmp[:, 1], "b--", lw=1, label="model ZMP y (1.6 s)")
side.plot(t, com.com[:, 1], "g-", lw=2, label="CoM y (1.6 s)")
side.set(xlabel="t [s]", ylabel="y [m]", title="lateral motion")
side.legend(loc="lower left")
fig.tight_layout()
figure = OUT / "tutorial_02.png"
fig.savefig(figure, dpi=80)
plt.close(fig)
print(f"figure: {figure}")

# %% [markdown]
# ## 4. The same walk, online: the `PatternGenerator` system
#
# `PatternGenerator` is the paper's `pg` entity, a Drake `LeafSystem` with one output
# sample per control tick (CoM, feet, waist, ZMP, contact phase, load). It plans online:
# footprints can be added while it walks, and the references already in its preview
# window are never changed, so a new footprint starts at the earliest one preview time
# later. Its commands are the original ones: `:stepseq x y yaw ...` gives each footprint
# in the frame of the other foot's last footprint (y > 0: left foot). Given all the steps
# at t = 0, it stands one preview time (1.6 s, our lead-in) and then walks the very
# samples that `FootstepPlan` made — the CoM it outputs is the offline plan's.

# %%
pg = PatternGenerator(left, right, com_height=Z_C, dt=DT, horizon=1.6, timing=timing)
simulator = Simulator(pg)
context = simulator.get_mutable_context()
width = stance_width(left, right)
triples = [(0.2, -width if k % 2 == 0 else width, 0.0) for k in range(5)]
triples += [(0.05, width if k % 2 == 0 else -width, math.pi / 10 if k < 4 else 0.0) for k in range(5)]
command = ":stepseq " + "  ".join(f"{x:g} {y:g} {yaw:.12g}" for x, y, yaw in triples)
print(command)
pg.parsecmd(context, command)
online_steps = [step for _, step in pg.planned_landings(context)]
footprint_error = max(
    math.hypot(a.x - b.x, a.y - b.y) + abs(a.yaw - b.yaw) for a, b in zip(online_steps, steps, strict=True)
)
print(f"footprints from :stepseq vs alternating_steps: largest difference {footprint_error:.1e}")

com_error = 0.0
for k in range(0, len(walk) - 1, 40):
    simulator.AdvanceTo(k * DT)
    planner = pg.planner(context)
    com_error = max(com_error, float(np.abs(planner.com[:2] - com.com[planner.k]).max()))
print(f"online CoM vs offline plan: largest difference {com_error:.1e} m")
assert footprint_error < 1e-9 and com_error < 1e-9

# %% [markdown]
# A command outside the documented bounds of `WALKING_BOUNDS` is refused, naming the
# bound — a 2 m step height would have sent the foot reference over the robot's head:

# %%
for bad in (":stepheight 2.0", ":singlesupporttime 1e-9"):
    try:
        pg.parsecmd(context, bad)
    except ValueError as refused:
        print(f"refused: {refused}")
print(
    "bounds: "
    + ", ".join(f"{name} [{b.low:g}, {b.high:g}] {b.unit}" for name, b in WALKING_BOUNDS.__dict__.items())
)
