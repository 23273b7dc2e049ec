"""The benchmark harness behind ``darcyan bench`` (:func:`darcyan.bench.runner.run_bench`; its
dataset folders in :mod:`~darcyan.bench.datasets`, its work in :mod:`~darcyan.bench.work`, what it
writes in :mod:`~darcyan.bench.report` and :mod:`~darcyan.bench.plots`).

The method names live here, light to import: the command line lists them in its help.
"""

METHODS = ("darcyan", "hks", "wks", "pyfm")
DENSE_METHODS = ("darcyan", "pyfm")  # dense maps of --dense (pyfm only when it is among the methods)
