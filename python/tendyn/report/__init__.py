"""HTML reports of the commands (docs/reports.md): one self-contained page per run, from result objects.

``report/`` turns results into pages and computes nothing (DESIGN). Its stable API:
:func:`write_html_report`, :func:`run_info`, :class:`Section`, :class:`Figure`, :class:`Table`,
:func:`section_of`, :func:`publish` (the one path of the commands' ``--report``) and :func:`write_beside`
(the page beside a grid command's table: sweep, zwidth).
"""

from tendyn.report.page import HTML_NAME, Figure, Section, Table, run_info, section_of, write_html_report
from tendyn.report.publish import publish, warn, write_beside, write_report

__all__ = ["HTML_NAME", "Figure", "Section", "Table", "publish", "run_info", "section_of", "warn",
           "write_beside", "write_html_report", "write_report"]
