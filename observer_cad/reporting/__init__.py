"""Stage 10 — reporting: text, Markdown/LaTeX, plots, CSV and interoperability exports.
"""
from ._analysis import (format_analysis, analysis_to_json)
from ._ensemble import (write_summary_csv, write_statistics_json, plot_ensemble_histograms)
from ._csv import (write_signals_csv, UNITS_FILE, with_decisions)
from ._interop import (linear_matrices, to_statespace, design_latex, design_latex_document, write_design_json, read_design_json, matrices_from_json, write_design_latex)
from ._markdown import (symbol_latex, expr_latex, latex_block, md_escape, design_section, render_report, lag_states, analysis_markdown, bank_markdown)
from ._plots import (plot_simulation, save_figure, plot_residuals, plot_confusion, residual_names, plot_monitor)
from ._text import (format_matrix, format_structure, format_design, structure_to_json, format_observer, format_observer_conditions, format_bank)

__all__ = [
    "write_summary_csv", "write_statistics_json", "plot_ensemble_histograms", "format_analysis",
    "analysis_to_json", "write_signals_csv", "UNITS_FILE", "with_decisions", "linear_matrices",
    "to_statespace", "design_latex", "design_latex_document", "write_design_json",
    "read_design_json", "matrices_from_json", "write_design_latex", "symbol_latex",
    "expr_latex", "latex_block", "md_escape", "design_section", "render_report", "lag_states",
    "analysis_markdown", "bank_markdown", "plot_simulation", "save_figure", "plot_residuals",
    "plot_confusion", "residual_names", "plot_monitor", "format_matrix", "format_structure", "format_design",
    "structure_to_json", "format_observer", "format_observer_conditions", "format_bank"
]
