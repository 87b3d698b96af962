"""The two-step route (issue 46 item 2): the table fit of a 30-manoeuvre
campaign (tests/table_campaign.py: alpha 0 .. 0.18 at 10 points x Mach 0.3,
0.5, 0.7; five derivatives a manoeuvre, 17 table values) against the 30
local fits it starts from, one after the other in this process.  The table
fit's time is the call mlid.fit_tables (the core's weights, solve and 30
chi-square tests, and the Python around it).

    python benchmarks/bench_table_fit.py
"""

import sys
import time
from pathlib import Path

import mlid

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent / "tests"))
from timing import median  # noqa: E402
import table_campaign as tc  # noqa: E402


def main():
    conds = tc.grid(10, [0.3, 0.5, 0.7])
    records = [tc.record(c, k) for k, c in enumerate(conds)]
    models = [tc.local_model(c) for c in conds]
    fits = lambda: [mlid.fit(m, d) for m, d in zip(models, records)]     # noqa: E731
    res = fits()
    tabs = tc.tables()
    t_local = median(fits, 5)
    cpu0 = time.process_time()
    fits()
    cpu_local = time.process_time() - cpu0
    t_table = median(lambda: mlid.fit_tables(res, tabs, conds), 50)
    out = mlid.fit_tables(res, tabs, conds)
    print(f"{len(conds)} manoeuvres, {len(out.theta)} local estimates, {len(out.names)} table "
          f"values, {tc.NT} samples a manoeuvre (median of 5 and 50 runs):")
    print(f"  30 local fits, one after another: {1e3 * t_local:8.1f} ms wall "
          f"({1e3 * cpu_local:.1f} ms CPU, {1e3 * t_local / len(conds):.2f} ms a fit)")
    print(f"  the two-step table fit:           {1e3 * t_table:8.2f} ms wall "
          f"({100 * t_table / t_local:.1f} % of the local fits)")
    print(f"  total chi2 {out.chi2_total:.1f} on {out.dof_total} dof, p = {out.p_total:.2f}; "
          f"disagree: {', '.join(out.disagree) or 'none'}")


if __name__ == "__main__":
    main()
