"""Compiled merges of two sorted time axes (one pass each, in place of several binary searches and
temporaries over millions of stamps)."""
from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True, nogil=True)
def place(t_grid, t, at_stamp, stale_ns):
    """Hold the messages at times ``t`` (sorted int64 ns) on the grid ``t_grid`` (sorted int64 ns).

    Returns (take, first_valid, stale_i, stale_age_ns, n_inside, merged):
    ``take[i]``: the message whose value sample i uses; with ``at_stamp`` the last message before the next
    grid time t_grid[i + 1] (it switches inside the interval, at its own time), else the last message at or
    before t_grid[i].  ``first_valid``: the first grid sample with a message at or before it (n if none).
    ``stale_i``: the first grid sample whose last message is more than ``stale_ns`` old (-1 if none).
    ``n_inside``: intervals whose value switches after their grid time; ``merged``: intervals that hold more
    than one message (only the last is used)."""
    n, m = t_grid.size, t.size
    take = np.empty(n, np.int64)
    j = -1
    u = -1
    prev = -1
    first_valid = n
    stale_i = -1
    stale_age = np.int64(0)
    n_inside = 0
    merged = 0
    for i in range(n):
        g = t_grid[i]
        while j + 1 < m and t[j + 1] <= g:
            j += 1
        if j >= 0:
            if first_valid == n:
                first_valid = i
            if stale_i < 0 and g - t[j] > stale_ns:
                stale_i = i
                stale_age = g - t[j]
        if at_stamp:
            if i + 1 < n:
                nxt = t_grid[i + 1]
                while u + 1 < m and t[u + 1] < nxt:
                    u += 1
            else:
                u = m - 1
            if u >= 0:
                if t[u] > g:
                    n_inside += 1
                if prev >= 0 and u - prev > 1:
                    merged += 1
                prev = u
            take[i] = max(u, 0)
        else:
            take[i] = max(j, 0)
    return take, first_valid, stale_i, stale_age, n_inside, merged


@njit(cache=True, nogil=True)
def lead_after_grid(t_grid, t):
    """For the messages inside [t_grid[0], t_grid[-1]]: how long after the preceding grid time each came [ns]."""
    n = t_grid.size
    k = 0
    for x in t:
        if t_grid[0] <= x <= t_grid[n - 1]:
            k += 1
    out = np.empty(k, np.int64)
    i = 0
    k = 0
    for x in t:
        if t_grid[0] <= x <= t_grid[n - 1]:
            while i + 1 < n and t_grid[i + 1] <= x:
                i += 1
            out[k] = x - t_grid[i]
            k += 1
    return out
