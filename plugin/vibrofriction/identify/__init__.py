"""Identification from measured data: fit a friction law with the plugin's own law code, trace
the residual to missing effects, select them, report the error before and after.

    from vibrofriction.identify import identify
    from vibrofriction.identify.report import write_report
    result = identify(read_dataset("run1.csv"), [read_dataset("run2.csv")], law="lugre")
    write_report(result, "out/")

Two paths share the forward selection (``driver``): the inverse path (``selection``: the law
fed the measured motion, its force fitted) and the simulation path (``simulation``: the MuJoCo
rig or a machine scene replayed along the record, every measured channel fitted).

Modules, from the bottom up (no cycle among them: tests/test_layout.py):

  own_effects ........... a researcher's own effects (a level factor over time, speed or
                          position), registered as candidates without editing the selection
  start ................. where a record starts: at rest, or in motion with the contact sliding
  record ................ a dataset prepared for the inverse fit: signals, target, law input grid
  model ................. the model's parameters and effects; the inverse model's prediction
  analysis .............. the residual against regressors, its spectrum, its autocorrelation
  fit ................... the inverse least squares (``Problem``), uncertainties, metrics
  driver ................ forward selection of effects over a path's back end (both paths)
  selection ............. the inverse path: baseline, candidates, judgement (``identify``)
  replay ................ the rig replayed in MuJoCo along a record (``RigReplay``, ``Replayer``)
  machine_replay ........ a machine scene (the EMPS) replayed in closed loop along a record
  replays ............... ``prepare_replay``: a record to the rig's replay or its machine's
  shooting .............. multiple shooting: segments whose start states are fitted too
  simulation ............ the simulation path: baseline starts, screening, judgement
                          (``identify_by_simulation``)
  series ................ the final model's predicted and residual series beside report.json
  identifiability ....... what the data cannot tell: uninformed values, residual outliers
  residual_diagnostics .. diagnostics of the final residual and a verdict on the model
  figures ............... the inverse path's figures (matplotlib)
  report ................ the inverse path's report.json and report.md (and its figures)
  simulation_report ..... the simulation path's report.json, report.md and figure
"""
from .model import EFFECTS, LAW_PARAMETERS
from .selection import BIC_THRESHOLD, MIN_IMPROVEMENT, Identification, identify

__all__ = ["identify", "Identification", "EFFECTS", "LAW_PARAMETERS", "BIC_THRESHOLD",
           "MIN_IMPROVEMENT"]
