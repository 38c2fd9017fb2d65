"""How many threads the linear algebra under iwp's fits may use.

iwp's parallel work is its own (the batch engine's lanes on all cores, a
sweep's chunks on workers). The linear algebra of a fit works on tall,
narrow Jacobians (thousands of rows, tens of columns), where OpenBLAS's
threads gain nothing and, on a machine whose cores are busy, spin: one
singular value decomposition of a 4806 x 24 Jacobian took 0.77 s with
OpenBLAS's default threads on a loaded 2-core machine and 0.0037 s with
one. :func:`one_blas_thread` limits the BLAS and LAPACK libraries to one
thread for the duration of a fit (:mod:`threadpoolctl`, whichever library
numpy and scipy load); the ``iwp`` command runs under it throughout.
"""

from __future__ import annotations

from threadpoolctl import threadpool_limits

__all__ = ["one_blas_thread"]


def one_blas_thread() -> threadpool_limits:
    """A context manager limiting BLAS/LAPACK to one thread (the previous limits restored on exit)."""
    return threadpool_limits(limits=1, user_api="blas")
