"""Diagnose: where the recording and the model disagree, which physics is missing, and the fit with it."""
