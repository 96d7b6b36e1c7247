"""The model room: the plant of eq. (1) (plant.py), from which the estimator's and the diagnosis' kernels take it."""
