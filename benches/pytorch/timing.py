"""The timing both anchor scripts share: median wall time of `step()` in ms over `reps` calls,
after 5 untimed calls."""
import statistics, time


def median_ms(step, reps):
    ts = []
    for i in range(reps + 5):
        t0 = time.perf_counter()
        step()
        if i >= 5:
            ts.append(time.perf_counter() - t0)
    return statistics.median(ts) * 1e3
