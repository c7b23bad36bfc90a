"""Design-rule findings (read results, compute none) and their JSON report."""
