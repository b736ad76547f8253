"""Trade studies: systems x weather cases x seeds x sweeps, scored with an error budget.

:mod:`.model` reads and checks the study file, :mod:`.plan` makes and validates every run,
:mod:`.runner` runs them resumably into one folder, :mod:`.statistics` writes ``scores.json`` and
``scores.csv``.
"""

from .model import FORMAT, Study, parse_study, read_study

__all__ = ["FORMAT", "Study", "parse_study", "read_study"]
