"""Scripts that print figures; run one as ``python -m benchmarks.bench_x`` from the repository
root (``make bench`` runs them all)."""
