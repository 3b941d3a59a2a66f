"""Records: the dataset format, converters of public data sets, synthetic records.

* ``datasets``: the CSV + JSON sidecar format (docs/dataset-format.md), read and written;
* ``convert``: converters of published measurements into that format;
* ``synthetic``: records made by the scipy reference (``vibrofriction.oracle``), with undeclared
  effects; like the oracle it reaches none of the native laws (tests/test_layout.py).
"""
