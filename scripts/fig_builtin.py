#!/usr/bin/env python3
"""The rig with MuJoCo's built-in friction (joint frictionloss, box-on-box contact, dcmotor
LuGre, springyield) against the vibrofriction plugin: master curves, F_F traces, timestep
convergence of the mean drive force (same as ``vibrofriction compare-builtin``)."""
from __future__ import annotations

import json
import sys

from vibrofriction.study import builtin, scripts
from vibrofriction.study.reproduce import comparison_config, comparison_json


def main(argv=None) -> int:
    args = scripts.parse(__doc__, argv)
    log = scripts.log()
    cmp_config = comparison_config(args.quick)
    log.stage(f"built-in comparison, ladder {list(cmp_config.ladder_steps)}")
    result = builtin.compare(scripts.config(args), cmp_config, progress=log.progress)
    paths = builtin.write_comparison(result, args.out)
    (args.out / "builtin.json").write_text(json.dumps(comparison_json(result), indent=2) + "\n")
    print(builtin.comparison_table(result))
    return scripts.done(paths["png"], paths["md"])


if __name__ == "__main__":
    sys.exit(main())
