"""The paper's simulation study (Gutowski & Leus, Tribology International 2012) and MuJoCo's
built-in friction beside the plugin.

  config.py ..... the paper's parameter sets, grids, timestep rule
  runner.py ..... many rig runs -> summaries / last-period traces
  figures.py .... Figs. 7-14 and master curves (compute + plot, PNG + CSV)
  overlays.py ... kinematic limits (plugin law code) and closed forms (analytic.py)
  claims.py ..... the paper's claims with this run's numbers: summary.md, claims.json
  builtin.py .... frictionloss, contact, dcmotor LuGre, springyield vs the plugin
  sweep.py ...... grids over v_a x f x k_t x F_N, local or on a Dask cluster
  reproduce.py .. everything in one call (``vibrofriction reproduce``)
  output.py ..... writing CSV tables and PNG figures, progress lines
  readme.py ..... docs/study.md and its figures from a reproduce folder
  scripts.py .... what every scripts/fig_*.py shares (arguments, backend, config)

Figures are drawn on matplotlib ``Figure`` objects (Agg canvas), never through pyplot.
"""
from .config import StudyConfig
from .reproduce import DEFAULT_OUT, reproduce

__all__ = ["StudyConfig", "reproduce", "DEFAULT_OUT"]
