"""Stage 10 — reporting: text, Markdown/LaTeX, plots, CSV and interoperability exports.
"""
from ._analysis import (format_analysis, analysis_to_json)
from ._ensemble import (write_summary_csv, write_statistics_json, plot_ensemble_histograms, SUMMARY_FILE, STATISTICS_FILE)
from ._csv import (write_signals_csv, UNITS_FILE, with_decisions, DECISION_COLUMNS, csv_cell)
from ._interop import (linear_matrices, to_statespace, design_latex, design_latex_document, write_design_json, read_design_json, matrices_from_json, write_design_latex)
from ._markdown import (symbol_latex, matrix_name_latex, matrix_latex, expr_latex, design_matrices_latex, design_equations_latex, observer_equations_latex, latex_block, md_escape, conditions_table, certificate_table, design_section, render_report, lag_states, analysis_markdown, bank_markdown)
from ._plots import (plot_simulation, save_figure, plot_residuals, plot_confusion, residual_names)
from ._text import (format_matrix, format_structure, format_design, structure_to_json, format_observer, format_observer_conditions, format_signature, format_bank)

__all__ = ["write_summary_csv", "write_statistics_json", "plot_ensemble_histograms", "SUMMARY_FILE", "STATISTICS_FILE", "format_analysis", "analysis_to_json", "write_signals_csv", "UNITS_FILE", "with_decisions", "DECISION_COLUMNS", "csv_cell", "linear_matrices", "to_statespace", "design_latex", "design_latex_document", "write_design_json", "read_design_json", "matrices_from_json", "write_design_latex", "symbol_latex", "matrix_name_latex", "matrix_latex", "expr_latex", "design_matrices_latex", "design_equations_latex", "observer_equations_latex", "latex_block", "md_escape", "conditions_table", "certificate_table", "design_section", "render_report", "lag_states", "analysis_markdown", "bank_markdown", "plot_simulation", "save_figure", "plot_residuals", "plot_confusion", "residual_names", "format_matrix", "format_structure", "format_design", "structure_to_json", "format_observer", "format_observer_conditions", "format_signature", "format_bank"]
