"""Archives: a run's Dataset, atomic netCDF writes and checked reads, the archive contract,
output targets and provenance. Imports core and solvers, never app (docs/architecture.md)."""
