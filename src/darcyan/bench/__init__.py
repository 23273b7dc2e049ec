"""The benchmark harness behind ``darcyan bench`` (:mod:`darcyan.bench.runner`).

The method names live here, light to import: the command line lists them in its help.
"""

METHODS = ("darcyan", "hks", "wks", "pyfm")
DENSE_METHODS = ("darcyan", "pyfm")  # dense maps of --dense (pyfm only when it is among the methods)
