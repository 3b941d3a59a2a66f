"""The study's documentation page, built from a ``reproduce`` output folder.

Copies the key figures (palette PNGs, < 150 kB each) into ``docs/figures/`` and writes
``docs/study.md`` with the claims table and the built-in comparison table, every number taken
from that folder's ``claims.json`` and ``builtin.md``. The README links to that page.
"""
from __future__ import annotations

import json
from pathlib import Path

from .claims import cell

KEY_FIGURES = (
    ("master_curves.png", "Master curves of the four laws with their kinematic limits"),
    ("fig08_traces_va0.75.png", "Fig. 8: reduction without a sign change (Dahl) at "
                                "v_a = 0.75 mm/s"),
    ("fig12_stiffness.png", "Fig. 12: the contact stiffness k_t changes the reduction"),
    ("fig14_experiment_master.png", "Fig. 14 analogue: the experimental configuration "
                                    "f = 2600 Hz, v_d = 0.31 mm/s"),
    ("builtin_comparison.png", "MuJoCo's built-in friction vs the plugin"),
)
MAX_BYTES = 150_000


def compact_png(source: Path, target: Path, max_bytes: int = MAX_BYTES) -> Path:
    """Copy ``source`` as a 256-colour palette PNG, shrinking it until under ``max_bytes``."""
    from PIL import Image
    target.parent.mkdir(parents=True, exist_ok=True)
    image = Image.open(source).convert("RGB")
    scale = 1.0
    while True:
        img = image if scale == 1.0 else image.resize(
            (int(image.width * scale), int(image.height * scale)), Image.LANCZOS)
        img.quantize(colors=256, method=Image.Quantize.MEDIANCUT).save(target, optimize=True)
        if target.stat().st_size <= max_bytes or scale < 0.4:
            return target
        scale *= 0.85


def _claims_table(claims: dict) -> list[str]:
    lines = ["| # | claim (paper) | computed | holds |", "|---|---|---|---|"]
    for i, c in enumerate(claims["claims"], 1):
        holds = {"no": "**no**", "partly": "*partly*"}.get(c["holds"], c["holds"])
        lines.append(f"| {i} | {cell(c['paper'])} | {cell(c['computed'])} | {holds} |")
    return lines


def _convergence(claims: dict) -> list[str]:
    """The study's steady-state line (claims.json of a reproduce run that has it)."""
    c = claims.get("convergence")
    if c is None:
        return []
    text = ("Every mean drive force is its steady state reached from rest (a run until its "
            "windowed mean settles, `vibrofriction.rigs.steady`; `--method periodic` solves "
            "for the orbits instead, `vibrofriction.rigs.periodic`): "
            f"{c['converged']} of {c['runs']} points converged to 0.1 %, each its run and its "
            "static run")
    if c["unconverged"]:
        text += "; not converged: " + "; ".join(
            f"{u['set']} {u['law']} kappa_v {u['kappa']:g}" for u in c["unconverged"])
    return [text + ". The built-in comparison runs fixed lengths: it compares timesteps.", ""]


def _builtin_table(builtin_md: str) -> list[str]:
    """The first table of builtin.md (the timestep comparison)."""
    lines, started = [], False
    for line in builtin_md.splitlines():
        if line.startswith("|"):
            lines.append(line)
            started = True
        elif started:
            break
    return lines


def _costs(builtin: dict, source: str = "this run") -> list[str]:
    """The converged master curve's cost by each route, when the run measured it
    (compare-builtin; reproduce leaves it out)."""
    costs = builtin.get("converged_costs")
    if not costs:
        return []
    from .builtin import converged_costs_table
    return [
        "### The converged master curve: what it costs by each route",
        "",
        f"{len(costs['kappas'])} values of kappa_v from {costs['kappas'][0]:g} to "
        f"{costs['kappas'][-1]:g} and the static run, per law family: CPU seconds (single "
        f"thread, side by side in {source}) to every point within "
        f"{costs['accuracy']:.0%} of the converged curve. **periodic**: the product's route "
        "(each point's periodic orbit; the transient where none is found); **transient**: the "
        "plugin run from rest until its windows settle; **built-in**: MuJoCo's element run "
        "from rest as long as the plugin's transient, at the coarsest refinement of the "
        f"rule's step within {costs['accuracy']:.0%}.",
        "",
        converged_costs_table(costs),
        ""]


def write_study_page(results: Path, docs: Path, *, figure_prefix: str = "figures",
                     costs_from: Path | None = None) -> Path:
    """docs/study.md from a reproduce run's folder; ``costs_from``: a ``compare-builtin``
    run's folder whose converged-curve costs the page shows (reproduce does not time them)."""
    results, docs = Path(results), Path(docs)
    claims = json.loads((results / "claims.json").read_text())
    builtin_md = (results / "builtin.md").read_text()
    builtin = json.loads((results / "builtin.json").read_text())
    costs, costs_source = builtin, "this run"
    if costs_from is not None:
        costs = json.loads((Path(costs_from) / "builtin.json").read_text())
        costs_source = "one run of `vibrofriction compare-builtin` on the same machine"
    figures = []
    for name, caption in KEY_FIGURES:
        target = compact_png(results / name, docs / figure_prefix / name)
        figures.append(f"![{caption}]({figure_prefix}/{target.name})")
    notes = [f"{i}. *{c['id']}*: {c['definition']}" + (f" {c['note']}" if c["note"] else "")
             for i, c in enumerate(claims["claims"], 1)]
    text = "\n".join([
        "# The paper's simulation study, reproduced",
        "",
        "[Back to the README](../README.md)",
        "",
        f"Every number and figure on this page comes from one run of `{claims['command']}` "
        f"(vibrofriction {claims['versions']['vibrofriction']}, MuJoCo "
        f"{claims['versions']['mujoco']}, {claims['wall_s']:.0f} s on 2 cores); the full "
        "summary with all figures is the `summary.md` that command writes. Figures: "
        "`scripts/fig_*.py` (one per figure) or `vibrofriction reproduce`; this page: "
        "`python scripts/fig_readme.py --results results`.",
        "",
        *_convergence(claims),
        figures[0], "", figures[1], "",
        "## The paper's claims, with this run's numbers",
        "",
        *_claims_table(claims),
        "",
        *notes,
        "",
        "Values the paper does not give are chosen once in `vibrofriction/params.py` "
        "(mu 0.2, k_d 1e6 N/m, alpha 1, Dupont z_ba/z_ss 0.7, LuGre sigma1 = 0.2 sqrt(k_t m), "
        "no Stribeck peak) — see its module docstring for the reasons.",
        "",
        figures[2], "", figures[3], "",
        "## MuJoCo's built-in friction in the same rig",
        "",
        f"`vibrofriction compare-builtin`: each variant is the rig scene edited with MjSpec "
        f"(friction plugin removed, one built-in element added). Timestep ladder "
        f"T/(N + 0.382), N = {', '.join(str(n) for n in builtin['ladder_steps_per_period'])}, "
        f"at kappa_v = {', '.join(f'{k:g}' for k in builtin['operating_kappas'])}; error of the "
        "mean drive force against the variant's own finest run (**own**) and against the "
        "finest run of the plugin law it models (**target**: Coulomb for frictionloss and "
        "contact, LuGre for dcmotor, Dupont z_ba/z_ss = 0.99 for springyield); cost: CPU time "
        f"(wall time) of one single-thread run of {builtin['duration_s'] * 1e3:.0f} ms "
        "simulated at the step reaching 1 % against the target (or its own, marked). ± marks "
        "a friction force that changes sign.",
        "",
        *_builtin_table(builtin_md),
        "",
        figures[4],
        "",
        *_costs(costs, costs_source),
    ])
    path = docs / "study.md"
    path.write_text(text)
    return path


__all__ = ["write_study_page", "compact_png", "KEY_FIGURES"]
