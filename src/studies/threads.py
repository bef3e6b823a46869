"""Threads of the numerical libraries a computation runs on."""

from __future__ import annotations

from contextlib import contextmanager

__all__ = ["single_thread_blas"]


@contextmanager
def single_thread_blas():
    """Run BLAS single-threaded within the block: the matrices of a filter's
    step, a regression per DOF or a least-squares step on a few tens of
    coefficients are small, where BLAS's threads cost more to start and wait
    for than they gain and, beside other work on the same cores (the
    filter's own threads, a sweep's other jobs), slow it down: a discovery
    on three simulated records took 16-17 s with OpenBLAS's threads and
    10-11 s without on two cores (threadpoolctl, a scikit-learn dependency;
    without it nothing changes)."""
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:  # pragma: no cover
        yield
        return
    with threadpool_limits(limits=1, user_api="blas"):
        yield
