"""Which integrators use the generated Jacobian: a module without sympy, so that a run whose equations come
from the derivation cache (mbs/derivation_cache.py) can decide it without loading the symbolic stages."""

#: Integrators that use a Jacobian: a scene naming one of them gets mbs_jacobian generated.
JACOBIAN_INTEGRATORS = frozenset({"rodasp", "rodas5p", "radau", "bdf", "lsoda", "cvode_bdf", "ida", "auto"})
