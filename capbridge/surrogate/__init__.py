"""Table loading, interpolation, fits and analytic reference formulas behind the public lookup API."""
