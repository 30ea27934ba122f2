"""Scoring: accuracy tables, confusion counts and the measures the benchmarks report."""
