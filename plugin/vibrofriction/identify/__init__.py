"""Identification from measured data: fit a friction law with the plugin's own law code, trace
the residual to missing effects, select them, report the error before and after.

    from vibrofriction.identify import identify, write_report
    result = identify(read_dataset("run1.csv"), [read_dataset("run2.csv")], law="lugre")
    write_report(result, "out/")

Modules: ``record`` (a dataset prepared for fitting, the law input grid), ``model`` (the
inverse model and its parameters), ``fit`` (least squares, uncertainties, metrics),
``analysis`` (residual vs regressors, spectrum, autocorrelation), ``selection`` (baseline,
candidates, forward selection), ``report`` (report.json, report.md), ``figures``.
"""
from .model import EFFECTS, LAW_PARAMETERS
from .selection import BIC_THRESHOLD, MIN_IMPROVEMENT, Identification, identify

__all__ = ["identify", "Identification", "EFFECTS", "LAW_PARAMETERS", "BIC_THRESHOLD",
           "MIN_IMPROVEMENT"]
