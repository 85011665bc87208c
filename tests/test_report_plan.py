"""The report's render plan (compare/render/plan.py): every role it names is one of its jobs,
and what a scene lacks is left out of the plan and named."""

from __future__ import annotations

import json
from pathlib import Path

from helpers import SCENES

from compare.judge.target_model import SWITCHABLE_EFFECTS
from compare.render.plan import (
    DEMO_SPPS,
    LADDER_ORDER,
    QUIRK_NAMES,
    RenderPlan,
    plan,
)


def _roles(p: RenderPlan) -> list[str]:
    keys = [p.reference.key, p.paper.key, p.penumbra_demo.key]
    keys += [j.key for j in p.demo_convergence.values()]
    keys += [f.job.key for f in p.featured] + [j.key for j in p.mapped]
    keys += [j.key for j in p.same_estimator_as_reference] + [s.job.key for s in p.ladder]
    for a in p.ablations:
        keys += [a.reference.key, *(j.key for j in (*a.demo.values(), *a.base.values()))]
    return keys + [j.key for j in (p.area, p.centre_reference) if j is not None]


def test_every_role_is_a_job_of_the_plan_and_keys_are_unique() -> None:
    p = plan(str(SCENES / "classic.json"), (64, 48))
    keys = [j.key for j in p.jobs()]
    assert len(keys) == len(set(keys)) == 43
    assert set(_roles(p)) <= set(keys)
    assert sorted(p.demo_convergence) == list(DEMO_SPPS)
    assert [a.effect for a in p.ablations] == list(SWITCHABLE_EFFECTS)
    assert [s.step.quirk for s in p.ladder] == [None, *LADDER_ORDER]
    assert sorted(LADDER_ORDER) == sorted(QUIRK_NAMES)
    # The ladder starts at the paper render and ends at physical mode, both planned once.
    assert p.ladder[0].job is p.paper and not p.ladder[0].fixes_one_quirk
    assert p.ladder[-1].job is p.penumbra_demo and not p.ladder[-1].fixes_one_quirk
    assert all(s.fixes_one_quirk for s in p.ladder[1:-1])
    assert p.reference in p.mitsuba() and p.reference not in p.charted()
    assert not {j.family for j in p.shown()} & {"ablation"}


def test_a_scene_without_light_plans_no_area_light_and_no_shadow_ablation(
    tmp_path: Path,
) -> None:
    scene = json.loads((SCENES / "classic.json").read_text())
    scene["spheres"] = [s for s in scene["spheres"] if "emission" not in s]
    path = tmp_path / "dark.json"
    path.write_text(json.dumps(scene))
    p = plan(str(path), (64, 48))
    assert p.area is None and "area light" in p.not_applicable
    assert "shadows" not in [a.effect for a in p.ablations]
    assert all(j.key != "ref-area" for j in p.jobs())


def test_sizes_reach_every_command() -> None:
    p = plan(str(SCENES / "paper.json"), (40, 32))
    for j in p.jobs():
        assert ("--size" in j.args) if j.tool == "rtval" else ("--width" in j.args), j.key
