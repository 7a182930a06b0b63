"""The harness: run scenarios, decompose the errors, write tables, figures and findings, and
compare with the committed baseline. See docs/running.md."""

from podbench.harness.metrics import decompose, norm_summaries
from podbench.harness.regress import compare, read_table
from podbench.harness.runner import COLUMNS, run_study, run_unit

__all__ = ["run_study", "run_unit", "decompose", "norm_summaries", "compare", "read_table",
           "COLUMNS"]
