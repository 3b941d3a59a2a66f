"""The sub-commands of ``vibrofriction``, one module each (registered in ``cli.COMMANDS``).

  simulate ......... one run of the rig: series to CSV, summary to JSON
  sweep ............ the master curve over a grid, local or on a Dask cluster
  reproduce ........ the paper's study: every figure and the claims summary
  compare_builtin .. MuJoCo's built-in friction beside the plugin
  convert .......... a third-party record to the dataset format
  identify ......... identification from measured records (vibrofriction.identify)
  info ............. versions, the plugin library and the plugins' attributes
  view ............. a bundled scene or a model file in MuJoCo's viewer
  common ........... what the commands share: --set parsing, JSON writing, usage errors
"""
