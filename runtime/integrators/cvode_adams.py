"""SUNDIALS CVODE with Adams-Moulton formulas (orders 1-12): smooth non-stiff models at tight tolerances,
where its high order takes few right-hand sides per unit of accuracy (NEWSIM's Adams method)."""

from __future__ import annotations

from .cvode_bdf import CvodeBdf
from .registry import register


@register
class CvodeAdams(CvodeBdf):
    name = "cvode_adams"
    description = "SUNDIALS CVODE, Adams orders 1-12 (non-stiff)"
    stiff = False
    method = "Adams"
