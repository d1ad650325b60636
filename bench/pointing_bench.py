"""Pointing by the signal (issue 38): the offset a cross scan finds, against the truth.

For beamwidths of 30 deg (a 2 m Yagi), 10 deg (70 cm) and 3 deg (a small S-band dish)
and SNRs of 3, 10 and 30 dB (the source's peak over the floor's per-sample radiometer
noise, urc.peaking.simsource): cross scans (+-1.5 beamwidths, 0.2-beamwidth steps,
``--samples`` readings averaged per point) of a beacon at az 120, el 30 through an
injected pointing error; the fitted offset's error on the sky (RMS, p95, in degrees and
in beamwidths), the share of scans refused (no significant peak) and the median stated
uncertainty. The beam and the noise are simulated without the control loop (the test
suite flies scans on the simulated rotator: tests/pointing/test_scan_sim.py); with
``--model``, also the residual of a pointing-model fit from N scans of the 3 deg beam.
With ``--steptrack``, the step-track row: the ISS (tests' fixture elements) flown on the
simulated rotator (virtual clock) with its elements shifted 30 s along track, the power
from the true satellite: the true beam's error from AOS + 30 s to LOS with step-track
and with the prediction alone, the time offset found (truth -30 s) and its error
(dt+30), the locks and losses of the signal in the pass (announced events) and the most
step-track's error exceeded the prediction's at the same instant; ``--quick`` flies the
10 deg beam only.
With ``--calibrate``, the time to a calibrated station: the Sun at Tartu on 2024-06-21
(Sun up 01:45..19:40Z, at most el 55), flown on the simulated rotator (virtual clock,
tartu-urc profile, 6 deg/s) through the same injected error (urc.testing.calibration_flight).
(a) One-scan offset calibration: from the antenna parked (az 0, el 90) at 09:00Z, the
rotator time from the command to the offset fitted (slew to the Sun + the cross scan
+ the fit, which takes no virtual time); a refused scan (noise) is flown again from where
it ended, up to 5 times, its time counted. Calibrated when the true beam, commanded at
the Sun through the fitted offset (the [offsets] ``urc calibrate sun`` offers), is off
it by under a tenth of the beamwidth; also the RMS over the sky (az 60..300, el 10..70)
with that one offset: a constant offset cannot take out a tilt or a sag.
(b) The pointing model: a Sun cross scan every 15 min of the day from when the Sun leaves
room for one (each leg +-1.5 beamwidths, narrowed to no less than 1 to keep its elevation
within 1..89 deg), the model (all terms; without NPAE when the scans cannot separate it)
fitted after each; calibrated when the corrected pointing RMS at fresh positions (the same
sky) is under a tenth of the beamwidth: the scans flown and refused, the rotator time, the
sky time (hours of the Sun's path from the first scan's command to the last one's end)
and the RMS reached, or the day's best if never. Scans have ``--samples`` readings per
point; ``--quick`` runs the 10 deg beam with 3 one-scan trials per cell (else 10).
Prints a table, writes JSON (default bench/results/pointing.json).
Usage: python bench/pointing_bench.py [--quick] [--samples N] [--model] [--steptrack] [--calibrate]
       [--json PATH]
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

from bench_report import write_json
from urc.pointing.fit import ScanRefused, fit_cross
from urc.pointing.model import PointingModel
from urc.pointing.model_fit import fit_model, scan_result
from urc.pointing.scan import cross_scan, offset_pose, pose_offset
from urc.peaking.simsource import SimulatedPower, SkySource

AZ_DEG, EL_DEG = 120.0, 30.0
ERROR = PointingModel(ia_deg=1.2, ie_deg=-1.8, ca_deg=0.3, an_deg=0.4, aw_deg=-0.3, tf_deg=0.9)


def one_scan(model, az, el, fwhm_deg, snr_db, samples, seed):
    src = SkySource.beacon(az, el)
    power = SimulatedPower(src, fwhm_deg=fwhm_deg, snr_db=snr_db, seed=seed)
    plan = cross_scan(fwhm_deg)
    u, pa, pe = (np.array(c) for c in zip(*plan.poses(src, 0.0)))
    ba, be = model.beam_from_mech(pa, pe)
    # ``samples`` readings per point, averaged as powers
    lin = np.mean([10 ** (power.measure(u, ba, be) / 10) for _ in range(samples)], axis=0)
    dx, dy = pose_offset(pa, pe, az, el)
    return fit_cross(dx, dy, lin, "linear", [p.leg for p in plan.points], fwhm_deg=fwhm_deg,
                     half_width_deg=plan.half_width_deg)


def truth(model, az, el):
    am, em = model.mech_from_beam(az, el)
    return tuple(float(v) for v in pose_offset(am, em, az, el))


def offset_row(fwhm_deg, snr_db, trials, samples):
    want = truth(ERROR, AZ_DEG, EL_DEG)
    errs, stated, refused = [], [], {}
    for seed in range(trials):
        try:
            fit = one_scan(ERROR, AZ_DEG, EL_DEG, fwhm_deg, snr_db, samples, seed)
        except ScanRefused as exc:
            refused[exc.reason] = refused.get(exc.reason, 0) + 1
            continue
        errs.append(math.hypot(fit.dx_deg - want[0], fit.dy_deg - want[1]))
        stated.append(math.hypot(fit.dx_err_deg, fit.dy_err_deg))
    e = np.array(errs)
    row = {"fwhm_deg": fwhm_deg, "snr_db": snr_db, "trials": trials, "samples_per_point": samples,
           "fitted": len(errs), "refused": refused}
    if len(e):
        row.update(rms_deg=float(np.sqrt(np.mean(e ** 2))), p95_deg=float(np.percentile(e, 95)),
                   rms_beamwidths=float(np.sqrt(np.mean(e ** 2)) / fwhm_deg),
                   stated_median_deg=float(np.median(stated)))
    return row


def model_rows(n_list, trials, samples):
    rows = []
    for n in n_list:
        resid, worst = [], []
        for k in range(trials):
            rng = np.random.default_rng(100 + k)
            pos = list(zip(rng.uniform(60, 300, n), rng.uniform(10, 70, n)))
            scans = []
            for i, (az, el) in enumerate(pos):
                try:
                    f = one_scan(ERROR, az, el, 3.0, 20.0, samples, 1000 * k + i)
                except ScanRefused:
                    continue
                scans.append(scan_result(*offset_pose(az, el, f.dx_deg, f.dy_deg), f))
            fit = fit_model(scans)
            # pointing error left after correction, at fresh positions
            test = list(zip(rng.uniform(60, 300, 50), rng.uniform(10, 70, 50)))
            left = []
            for az, el in test:
                ba, be = ERROR.beam_from_mech(*fit.model.mech_from_beam(az, el))
                left.append(math.hypot(((ba - az + 180) % 360 - 180) * math.cos(math.radians(el)), be - el))
            resid.append(fit.residual_rms_deg)
            worst.append(float(np.sqrt(np.mean(np.square(left)))))
        rows.append({"scans": n, "trials": trials, "fit_residual_rms_deg": float(np.mean(resid)),
                     "corrected_pointing_rms_deg": float(np.mean(worst))})
    return rows


def steptrack_rows(beamwidths, snrs):
    import tempfile
    from pathlib import Path

    from urc.testing.steptrack_flight import fly_steptrack_pass, shifted_elements
    from urc.tracking.elements import load_elements
    from urc.tracking.passes import find_passes
    from urc.tracking.station import Station

    fixtures = Path(__file__).resolve().parent.parent / "tests" / "tracking" / "fixtures"
    t0 = 1704110400.0  # 2024-01-01T12:00Z, as the tracking tests
    station = Station(58.3780, 26.7290, 70.0, "Tartu")
    es = next(s for s in load_elements(fixtures / "leo.tle") if s.norad_id == 25544)
    wrong = shifted_elements(es, 30.0)
    p = max(find_passes(wrong, station, t0, duration_s=86400, min_el_deg=0), key=lambda q: q.max_el_deg)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for i, w in enumerate(beamwidths):
            alone = fly_steptrack_pass(es, wrong, station, p, Path(tmp) / f"a{i}", fwhm_deg=w, snr_db=10.0,
                                       step_track=False)
            after = alone.t_unix_s >= p.aos_unix_s + 30.0
            base = alone.error_deg[after]
            for j, snr in enumerate(snrs):
                f = fly_steptrack_pass(es, wrong, station, p, Path(tmp) / f"s{i}{j}", fwhm_deg=w, snr_db=snr, seed=j + 1)
                e = f.error_deg[f.t_unix_s >= p.aos_unix_s + 30.0]
                # the prediction alone's error at the same instants: how much worse step-track is at worst
                over = e - np.interp(f.t_unix_s[f.t_unix_s >= p.aos_unix_s + 30.0], alone.t_unix_s, alone.error_deg)
                st = (f.tracker_status or {}).get("step_track") or {}
                rows.append({"fwhm_deg": w, "snr_db": snr, "max_el_deg": round(p.max_el_deg, 1),
                             "rms_deg": float(np.sqrt(np.mean(e ** 2))), "p95_deg": float(np.percentile(e, 95)),
                             "within_quarter_pct": float(100 * np.mean(e <= w / 4)),
                             "prediction_rms_deg": float(np.sqrt(np.mean(base ** 2))),
                             "prediction_within_quarter_pct": float(100 * np.mean(base <= w / 4)),
                             "time_offset_s": f.time_offset_s, "time_offset_err_s": f.time_offset_err_s,
                             "time_offset_bias_s": None if f.time_offset_s is None else f.time_offset_s + 30.0,
                             "locks": sum("found by its signal" in x for x in f.events),
                             "losses": sum("signal lost" in x for x in f.events),
                             "worst_over_prediction_deg": float(over.max()),
                             "fits": st.get("fits"), "programs": f.programs})
    return rows


CAL_T0_UNIX_S = 1718928000.0  # 2024-06-21T00:00Z: midsummer at Tartu, the Sun up 01:45..19:40Z, el to 55
CAL_ONE_SCAN_AT_S = 9 * 3600.0  # the one-scan calibration commanded at 09:00Z (Sun near el 52)
CAL_EVERY_S = 900.0             # the day's Sun scans: one every 15 min while the Sun leaves room
CAL_MAX_ATTEMPTS = 5


def calibrate_rows(beamwidths, snrs, trials, samples):
    """Time to a calibrated station (module docstring): the one-scan offset and the model."""
    import logging
    import tempfile
    from pathlib import Path

    from urc.errors import CalibrationError
    from urc.pointing.model import TERMS
    from urc.testing.calibration_flight import SunCalibrator, corrected_error_deg, mech_pose, sky_rms_deg
    from urc.tracking.station import Station

    logging.getLogger("urc").setLevel(logging.WARNING + 1)  # each fresh rotator's "first start" notice
    station = Station(58.3780, 26.7290, 70.0, "Tartu")
    rng = np.random.default_rng(7)
    fresh = (rng.uniform(60, 300, 300), rng.uniform(10, 70, 300))
    uncorrected = sky_rms_deg(ERROR, fresh)
    off_rows, model_rows_ = [], []
    with tempfile.TemporaryDirectory() as tmp:
        for w in beamwidths:
            for snr in snrs:
                # (a) one scan, from the park position, repeated on refusal
                times, tries, errs, sky, refused = [], [], [], [], {}
                for k in range(trials):
                    cal = SunCalibrator(station, ERROR, fwhm_deg=w, snr_db=snr, seed=1 + k, samples_per_point=samples,
                                        state_dir=Path(tmp) / f"o{w}-{snr}-{k}")
                    t = CAL_T0_UNIX_S + CAL_ONE_SCAN_AT_S + 120.0 * k
                    for attempt in range(1, CAL_MAX_ATTEMPTS + 1):
                        s = cal.scan(t + cal.clock.now_s())
                        if s is None:
                            break
                        if s.fit is None:
                            refused[s.refused] = refused.get(s.refused, 0) + 1
                            continue
                        off = (s.fit.dx_deg, s.fit.dy_deg)
                        times.append(cal.clock.now_s())
                        tries.append(attempt)
                        errs.append(float(corrected_error_deg(ERROR, s.mid_az_deg, s.mid_el_deg, offset=off)))
                        sky.append(sky_rms_deg(ERROR, fresh, offset=off))
                        break
                e = np.array(errs)
                row = {"fwhm_deg": w, "snr_db": snr, "trials": trials, "fitted": len(errs), "refused": refused,
                       "uncorrected_at_sun_deg": float(corrected_error_deg(ERROR, *cal.sun(t))),
                       "uncorrected_sky_rms_deg": uncorrected}
                if len(e):
                    row.update(time_median_s=float(np.median(times)), time_max_s=float(np.max(times)),
                               attempts_max=int(max(tries)), error_at_sun_median_deg=float(np.median(e)),
                               error_at_sun_max_deg=float(e.max()),
                               under_tenth=int(np.sum(e < w / 10)), offset_sky_rms_median_deg=float(np.median(sky)))
                off_rows.append(row)

                # (b) the pointing model: the Sun through a day, a fit after every scan
                cal = SunCalibrator(station, ERROR, fwhm_deg=w, snr_db=snr, seed=99, samples_per_point=samples,
                                    state_dir=Path(tmp) / f"m{w}-{snr}")
                scans, flown, m_refused, rot_s, first, last, best, met, terms_used = [], 0, {}, 0.0, None, None, None, None, ""
                for t in np.arange(CAL_T0_UNIX_S, CAL_T0_UNIX_S + 86400.0, CAL_EVERY_S):
                    s = cal.scan(float(t))
                    if s is None:
                        continue
                    flown += 1
                    rot_s += s.duration_s
                    first = s.t_unix_s if first is None else first
                    last = s.t_unix_s + s.duration_s
                    if s.fit is None:
                        m_refused[s.refused] = m_refused.get(s.refused, 0) + 1
                        continue
                    scans.append(scan_result(*mech_pose(s), s.fit))
                    if 2 * len(scans) <= len(TERMS):
                        continue
                    fit = None
                    for terms in (TERMS, tuple(x for x in TERMS if x != "npae")):
                        try:
                            fit = fit_model(scans, terms)
                            break
                        except (CalibrationError, ValueError):  # too few to separate, or a term beyond +-10 deg
                            continue
                    if fit is None:
                        continue
                    rms = sky_rms_deg(ERROR, fresh, model=fit.model)
                    if best is None or rms < best["rms_deg"]:
                        best = {"rms_deg": rms, "scans_fitted": len(scans), "terms": ",".join(fit.terms)}
                    if rms < w / 10:
                        met = s.t_unix_s + s.duration_s
                        terms_used = ",".join(fit.terms)
                        break
                end = met if met is not None else last
                model_rows_.append({
                    "fwhm_deg": w, "snr_db": snr, "met": met is not None, "scans_flown": flown,
                    "scans_refused": m_refused, "scans_fitted": len(scans), "rotator_s": round(rot_s, 1),
                    "sky_hours": None if first is None or end is None else round((end - first) / 3600.0, 2),
                    "first_scan_utc_h": None if first is None else round((first - CAL_T0_UNIX_S) / 3600.0, 2),
                    "corrected_sky_rms_deg": best["rms_deg"] if best else None,
                    "best_at_scans": best["scans_fitted"] if best else None,
                    "terms": terms_used or (best["terms"] if best else "")})
    return off_rows, model_rows_


def print_calibrate(off_rows, model_rows_):
    r0 = off_rows[0]
    print(f"\ntime to a calibrated station: the Sun at Tartu, 2024-06-21; uncorrected error at the Sun "
          f"{r0['uncorrected_at_sun_deg']:.2f} deg, over the sky (az 60..300, el 10..70) RMS {r0['uncorrected_sky_rms_deg']:.2f} deg")
    print("(a) one-scan offset: from park (az 0, el 90) at 09:00Z: slew + cross scan + fit, rescanned on refusal")
    print(f"{'FWHM deg':>8} {'SNR dB':>6} {'fit/try':>7} {'refused':>7} {'t med s':>7} {'t max s':>7} {'tries':>5} "
          f"{'err@Sun med':>11} {'max':>6} {'<FWHM/10':>8} {'sky RMS':>7}")
    for r in off_rows:
        head = (f"{r['fwhm_deg']:8g} {r['snr_db']:6g} {r['fitted']:>3d}/{r['trials']:<3d} "
                f"{sum(r['refused'].values()):7d} ")
        if "time_median_s" in r:
            print(head + f"{r['time_median_s']:7.1f} {r['time_max_s']:7.1f} {r['attempts_max']:5d} "
                  f"{r['error_at_sun_median_deg']:11.3f} {r['error_at_sun_max_deg']:6.3f} "
                  f"{r['under_tenth']:>4d}/{r['fitted']:<3d} {r['offset_sky_rms_median_deg']:7.3f}")
        else:
            print(head + "   never calibrated")
    print(f"(b) pointing model: a Sun cross scan every {CAL_EVERY_S / 60:g} min from when the Sun leaves room for "
          f"one; fitted after each; until the corrected RMS over the sky < FWHM/10")
    print(f"{'FWHM deg':>8} {'SNR dB':>6} {'met':>4} {'flown':>5} {'refused':>7} {'fitted':>6} {'rot s':>6} "
          f"{'sky h':>5} {'from h':>6} {'RMS deg':>8} {'at':>3}  terms")
    for r in model_rows_:
        rms = r["corrected_sky_rms_deg"]
        print(f"{r['fwhm_deg']:8g} {r['snr_db']:6g} {'yes' if r['met'] else 'no':>4} {r['scans_flown']:5d} "
              f"{sum(r['scans_refused'].values()):7d} {r['scans_fitted']:6d} {r['rotator_s']:6.0f} "
              + (f"{r['sky_hours']:5.2f} {r['first_scan_utc_h']:6.2f} " if r["sky_hours"] is not None else f"{'-':>5} {'-':>6} ")
              + (f"{rms:8.3f} {r['best_at_scans']:3d}  {r['terms']}" if rms is not None else f"{'-':>8} {'-':>3}"))
    easy = sorted({r["fwhm_deg"] for r in model_rows_ if r0["uncorrected_sky_rms_deg"] < r["fwhm_deg"] / 10})
    if easy:
        print(f"(the {', '.join(f'{w:g}' for w in easy)} deg beam is within a tenth uncorrected: its 'met' is the first fit)")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="20 scans per cell (else 200)")
    ap.add_argument("--samples", type=int, default=5, help="readings averaged per scan point")
    ap.add_argument("--model", action="store_true", help="also the pointing-model fit from N scans")
    ap.add_argument("--steptrack", action="store_true", help="also step-track against the prediction alone")
    ap.add_argument("--calibrate", action="store_true", help="also the time to a calibrated station")
    ap.add_argument("--json", default="bench/results/pointing.json")
    args = ap.parse_args()
    trials = 20 if args.quick else 200
    t0 = time.perf_counter()
    rows = [offset_row(w, s, trials, args.samples) for w in (30.0, 10.0, 3.0) for s in (3.0, 10.0, 30.0)]
    print(f"cross scan fitted offset error (truth: the injected model's offset, "
          f"{math.hypot(*truth(ERROR, AZ_DEG, EL_DEG)):.2f} deg), {trials} scans per cell, "
          f"{args.samples} readings per point")
    print(f"{'FWHM deg':>8} {'SNR dB':>6} {'fitted':>6} {'refused':>8} {'RMS deg':>8} {'p95 deg':>8} "
          f"{'RMS/FWHM':>8} {'stated':>7}")
    for r in rows:
        ok = "rms_deg" in r
        print(f"{r['fwhm_deg']:8g} {r['snr_db']:6g} {r['fitted']:6d} {sum(r['refused'].values()):8d} "
              + (f"{r['rms_deg']:8.3f} {r['p95_deg']:8.3f} {r['rms_beamwidths']:8.4f} {r['stated_median_deg']:7.3f}"
                 if ok else f"{'-':>8} {'-':>8} {'-':>8} {'-':>7}"))
    out = {"offset": rows, "samples_per_point": args.samples, "trials": trials,
           "injected_model": ERROR.as_dict()}
    if args.model:
        mrows = model_rows([8, 16, 32], 3 if args.quick else 10, args.samples)
        print("\npointing-model fit (3 deg beam, SNR 20 dB, scans at random az 60..300, el 10..70)")
        print(f"{'scans':>5} {'fit resid RMS deg':>18} {'corrected RMS deg':>18}")
        for r in mrows:
            print(f"{r['scans']:5d} {r['fit_residual_rms_deg']:18.4f} {r['corrected_pointing_rms_deg']:18.4f}")
        out["model"] = mrows
    if args.steptrack:
        srows = steptrack_rows((10.0,) if args.quick else (30.0, 10.0, 3.0), (3.0, 10.0, 30.0))
        print("\nstep-track: ISS, elements 30 s off along track (time offset -30 s), error from AOS+30 s to LOS")
        print(f"{'FWHM deg':>8} {'SNR dB':>6} {'RMS deg':>8} {'p95 deg':>8} {'<FWHM/4':>8} {'pred RMS':>8} "
              f"{'pred <FWHM/4':>12} {'dt s':>7} {'+-':>5} {'dt+30':>6} {'fits':>4} {'lock/loss':>9} "
              f"{'>pred deg':>9}")
        for r in srows:
            dt = r["time_offset_s"]
            print(f"{r['fwhm_deg']:8g} {r['snr_db']:6g} {r['rms_deg']:8.3f} {r['p95_deg']:8.3f} "
                  f"{r['within_quarter_pct']:7.1f}% {r['prediction_rms_deg']:8.3f} "
                  f"{r['prediction_within_quarter_pct']:11.1f}% "
                  + (f"{dt:7.2f} {r['time_offset_err_s']:5.2f} {dt + 30.0:+6.2f} {r['fits']:4d}" if dt is not None
                     else f"{'-':>7} {'-':>5} {'-':>6} {'-':>4}")
                  + f" {r['locks']:>4d}/{r['losses']:<4d} {r['worst_over_prediction_deg']:9.2f}")
        out["steptrack"] = srows
    if args.calibrate:
        crows, cmrows = calibrate_rows((10.0,) if args.quick else (30.0, 10.0, 3.0), (3.0, 10.0, 30.0),
                                       3 if args.quick else 10, args.samples)
        print_calibrate(crows, cmrows)
        out["calibrate_offset"], out["calibrate_model"] = crows, cmrows
    out["wall_s"] = round(time.perf_counter() - t0, 2)
    print(f"\n{out['wall_s']} s")
    write_json(out, args.json)


if __name__ == "__main__":
    main()
