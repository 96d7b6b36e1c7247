"""File formats: reading logs and parameter files, writing results atomically. No maths here."""
