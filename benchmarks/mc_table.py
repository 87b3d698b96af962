"""The table both Monte Carlo benchmarks print: per parameter, the sample
standard deviation of the estimates against the mean Cramer-Rao sigma."""

def print_table(mc, runs, wall, target):
    ok = mc["status"] == 0
    est, sig = mc["estimates"][ok], mc["sigma"][ok]
    print(f"{runs} identifications in {wall:.3f} s ({1e3 * wall / runs:.2f} ms each), "
          f"{ok.sum()} succeeded, mean iterations {mc['iterations'][ok].mean():.1f}")
    print(f"{'parameter':<10}{'truth':>11}{'mean est':>11}{'sample sd':>11}{'mean CR sd':>11}"
          f"{'ratio':>8}")
    worst = 0.0
    for k, name in enumerate(mc["names"]):
        sd, cr = est[:, k].std(ddof=1), sig[:, k].mean()
        worst = max(worst, abs(sd / cr - 1))
        print(f"{name:<10}{mc['truth'][k]:11.4g}{est[:, k].mean():11.4g}{sd:11.4g}{cr:11.4g}"
              f"{sd / cr:8.3f}")
    print(f"largest |sample sd / CR sd - 1| = {worst:.3f}: "
          f"{'within' if worst < target else 'OUTSIDE'} {100 * target:.0f}%")
