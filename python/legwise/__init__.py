"""legwise from Python: the kinematic identification (calibration) of parallel mechanisms.

The same library as the ``legwise`` command line, one import away::

    import legwise
    report = legwise.identify("models/5r.yaml", "measurements.csv")
    report.to_dict()          # the JSON report of `legwise identify --json` (docs/report.md)
    report.parameters["l1"]   # (identified value, standard deviation)

Measurements are a CSV path, or columns named as in the CSV (a dict of column name to 1-D
array, or a pandas DataFrame): numbers in SI units, ``leg`` as strings, a missing reading as
NaN. Errors are :class:`LegwiseError` (a ``ValueError``) with legwise's own message.
"""

from ._columns import Columns, read_csv_text
from ._commands import Measurements, Model, evaluate, identify, select, sets, simulate
from ._errors import LegwiseError
from ._mechanism import Mechanism, Parameter
from ._printer import ImportedPrinter, PrinterExport, export_printer, import_printer
from ._reports import Evaluation, FactorSets, Report

__all__ = [
    "identify",
    "simulate",
    "select",
    "evaluate",
    "sets",
    "import_printer",
    "export_printer",
    "read_csv_text",
    "Mechanism",
    "Parameter",
    "Report",
    "Evaluation",
    "FactorSets",
    "ImportedPrinter",
    "PrinterExport",
    "Columns",
    "LegwiseError",
    "Measurements",
    "Model",
]
