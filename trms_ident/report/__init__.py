"""Results on disk: JSON summary, estimate traces (CSV) and a self-contained HTML report."""
