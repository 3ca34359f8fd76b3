"""The learned discrepancy: what the identified model still misses on the unit's healthy BITs,
as a low-dimensional correction that depends on the flight condition.

Identification fits the parameters our plant has; a unit also carries what no parameter of
it expresses (a housekeeping load on the supply, a sensor's offset or gain, a friction law
other than Coulomb plus viscous, another control law or loop rate). Every commissioning BIT
flies the one BIT profile, so what the model misses is, BIT after BIT, a similar time series:
a mean shape, plus a few shapes whose amounts change with the condition. In the spirit of
Kennedy and O'Hagan's model calibration (model plus a discrepancy term learned on the data),
per fit signal (:data:`~mapr_daemon.reasoner.commissioning.bits.FIT_SIGNALS`, on the fit's
decimated grid, in sensor-noise units):

* the residual of each healthy BIT, record minus identified model (at the unit's friction);
* first, per signal, the part that follows the aircraft bus's drift within the BIT (read from
  the record's own SMPS input voltage and current, :func:`bus_drift`): the model flies the bus's
  mean, and below the supply floor the converter passes the drift on. Two coefficients per
  signal (drift, and drift while below the floor), least squares, or none;
* the correction is the residuals' mean plus ``rank`` principal components, each component's
  amount a kernel ridge regression on the BIT's condition features (:data:`FEATURES`: dynamic
  pressure, ambient temperature, aircraft bus, how far the bus sits below the supply floor and
  whether it does: there the converter changes regime), linear or linear plus a Gaussian term;
* per signal the drift term (on or off), the rank (0 = the mean alone, up to
  :data:`MAX_RANK`), the ridge penalty and the kernel are chosen by leave-one-out: each
  BIT's residual predicted from the others', the choice with the smallest held-out RMS
  wins (criterion: leave-one-out held-out RMS; a tie keeps the simpler choice). The
  held-out RMS of "no correction" and of the chosen one are kept: they say how much of the
  misfit the correction explains on BITs it was not fitted on, and the chosen one's is the
  signal's healthy spread used to weigh residuals later.

Nothing here names a model-form option: a constant load, an offset, a gain on a signal that
follows the fixed profile, or an unmodelled friction law all show as a mean shape and a
condition-dependent amount. What varies from flight to flight without following the condition
(a drifting load, the grease's scatter) stays in the held-out spread.

Saved as an ``.npz`` beside the commissioning record (:meth:`Discrepancy.save`).
"""

from __future__ import annotations

import dataclasses
import json
import zipfile
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from mapr_daemon.arrays import FloatArray
from mapr_daemon.ema.params import ActuatorParams
from mapr_daemon.errors import ConfigError
from mapr_daemon.reasoner.commissioning.bits import FIT_SIGNALS, BitRecord, condition
from mapr_daemon.reasoner.commissioning.flight import (
    Flight,
    decimated,
    fly,
    noise_scale,
    recorded,
)
from mapr_daemon.reasoner.diagnosis.healthy_model import supply_floor_v

FEATURES = ("dynamic_pressure_pa", "ambient_c", "bus_v", "below_floor_v", "at_floor")
MAX_RANK = 4
RIDGES = (0.1, 1.0, 10.0)
"""Ridge penalties tried, on standardised features (in units of one BIT's weight)."""
LENGTHS = (0.0, 1.0, 2.0)
"""Kernel lengths tried, in feature sds (0: the linear kernel alone)."""
SPREAD_SMOOTH = 9
"""Decimated steps (45 ms at the default grid) the per-time healthy spread is averaged over."""
MIN_BITS = 3
"""Fewer healthy BITs than this leave nothing to hold out: no discrepancy is learned."""
FORMAT = "mapr-discrepancy/1"


def bus_drift(params: ActuatorParams, bit: BitRecord, decimate: int) -> FloatArray:
    """The aircraft bus's departure from its mean within the BIT, on the decimated grid
    ``(T,)``: the SMPS input voltage plus the feeder drop, as
    :func:`~mapr_daemon.reasoner.commissioning.bits.condition` reads the mean."""
    bus = decimated(bit.channels["smps_input_voltage_v"] + params.bus.source_resistance_ohm
                    * bit.channels["smps_input_current_a"], decimate)
    out: FloatArray = bus - bus.mean()
    return out


def drift_regressors(feats: FloatArray, drift: FloatArray) -> FloatArray:
    """(n, 2, T): the drift, and the drift where the bus is below the supply floor."""
    at_floor = np.atleast_2d(feats)[:, FEATURES.index("at_floor")]
    drift = np.atleast_2d(drift)
    return np.stack([drift, drift * at_floor[:, None]], axis=1)


def features(params: ActuatorParams, bit: BitRecord) -> FloatArray:
    """The BIT's condition features (:data:`FEATURES`), read from its own channels."""
    ambient, bus = condition(params, bit)
    below = max(supply_floor_v(params) - bus, 0.0)
    return np.array([bit.dynamic_pressure_pa, ambient, bus, below, float(below > 0.0)])


@dataclasses.dataclass(frozen=True)
class SignalFit:
    """One signal's correction: mean shape, components and how their amounts follow the
    condition (all in noise units of :attr:`Discrepancy.scale`).

    The amounts are a kernel ridge regression on the standardised features of the BITs it was
    learned on: kernel ``x.y + exp(-|x - y|^2 / 2 length^2)`` (``length`` 0: the linear term
    alone, an ordinary ridge regression), so a regime change (the converter at its duty
    limit below the supply floor) or a load that grows faster than linearly with the dynamic
    pressure can be followed when the held-out residual says it helps."""

    drift: FloatArray
    """(2,) coefficients on :func:`drift_regressors`."""
    mean: FloatArray
    """(T,)"""
    basis: FloatArray
    """(rank, T), orthonormal rows."""
    dual: FloatArray
    """(n, rank): the kernel regression's coefficients over the learning BITs."""
    ridge: float
    length: float
    held_out_none: float
    """Leave-one-out RMS with no correction (the identified model's own misfit)."""
    held_out: float
    """Leave-one-out RMS with the chosen correction."""
    spread: FloatArray
    """(T,) the chosen correction's leave-one-out RMS at each time (over the BITs, smoothed
    over :data:`SPREAD_SMOOTH` steps, at least 1): where in the profile a healthy BIT is
    expected to depart from the prediction (a transient more than a hold)."""

    @property
    def rank(self) -> int:
        return int(self.basis.shape[0])


def kernel(a: FloatArray, b: FloatArray, length: float) -> FloatArray:
    """The regression kernel between standardised feature rows ``a (n, F)`` and ``b (m, F)``."""
    k: FloatArray = a @ b.T
    if length > 0.0:
        d2 = np.sum((a[:, None, :] - b[None, :, :]) ** 2, axis=2)
        k = k + np.exp(-0.5 * d2 / length**2)
    return k


@dataclasses.dataclass(frozen=True)
class Discrepancy:
    """The unit's learned correction to the identified model, per fit signal."""

    decimate: int
    scale: FloatArray
    """(K,) noise unit per signal (sensor noise of a ``decimate``-sample mean)."""
    center: FloatArray
    spread: FloatArray
    """(F,) the features' mean and sd over the BITs it was learned on."""
    learned_on: FloatArray
    """(n, F) the standardised features of the BITs it was learned on."""
    fits: tuple[SignalFit, ...]

    @property
    def bits(self) -> int:
        return int(self.learned_on.shape[0])

    def correction(self, feats: FloatArray, drift: FloatArray) -> FloatArray:
        """The correction for BITs of condition features ``feats`` ``(n, F)`` and bus drift
        ``(n, T)`` (:func:`bus_drift`): ``(n, K, T)`` in channel units, to add to the
        identified model's prediction."""
        x = (np.atleast_2d(feats) - self.center) / self.spread
        reg = drift_regressors(feats, drift)
        out = np.stack([f.mean[None, :] + (kernel(x, self.learned_on, f.length) @ f.dual)
                        @ f.basis + np.einsum("j,njt->nt", f.drift, reg)
                        for f in self.fits], axis=1)
        scaled: FloatArray = out * self.scale[None, :, None]
        return scaled

    def healthy_spread(self) -> FloatArray:
        """(K, T) per signal and time the held-out RMS left by model plus correction, channel
        units: how far a healthy BIT is expected to sit from the prediction."""
        out: FloatArray = np.stack([f.spread for f in self.fits]) * self.scale[:, None]
        return out

    def summary(self) -> dict[str, object]:
        """What the record keeps: per signal the rank, ridge, kernel length and held-out RMS
        without and with the correction (noise units)."""
        return {
            "criterion": "leave-one-out held-out RMS per signal",
            "bits": self.bits,
            "features": list(FEATURES),
            "signals": {k: {"rank": f.rank, "ridge": f.ridge, "length": f.length,
                            "held_out_rms_model": round(f.held_out_none, 4),
                            "held_out_rms_corrected": round(f.held_out, 4)}
                        for k, f in zip(FIT_SIGNALS, self.fits, strict=True)},
        }

    def save(self, path: str | Path) -> None:
        arrays: dict[str, FloatArray] = {"scale": self.scale, "center": self.center,
                                         "spread": self.spread, "learned_on": self.learned_on}
        for k, f in zip(FIT_SIGNALS, self.fits, strict=True):
            arrays[f"{k}.drift"] = f.drift
            arrays[f"{k}.mean"] = f.mean
            arrays[f"{k}.basis"] = f.basis
            arrays[f"{k}.dual"] = f.dual
            arrays[f"{k}.spread"] = f.spread
        meta = {"format": FORMAT, "decimate": self.decimate,
                "signals": list(FIT_SIGNALS), "features": list(FEATURES),
                "fits": [[f.ridge, f.length, f.held_out_none, f.held_out] for f in self.fits]}
        with open(path, "wb") as fh:
            np.savez(fh, meta=np.array(json.dumps(meta)), **arrays)  # type: ignore[arg-type]

    @classmethod
    def load(cls, path: str | Path) -> Discrepancy:
        """Read :meth:`save`'s file; :class:`ConfigError` naming what is wrong."""
        try:
            with np.load(path, allow_pickle=False) as z:
                meta = json.loads(str(z["meta"]))
                if meta.get("format") != FORMAT:
                    raise ConfigError(f"expected format {FORMAT}", path=str(path),
                                      field="format")
                if (tuple(meta["signals"]) != FIT_SIGNALS
                        or tuple(meta["features"]) != FEATURES):
                    raise ConfigError("signals or features differ from this version's",
                                      path=str(path))
                fits = tuple(SignalFit(z[f"{k}.drift"], z[f"{k}.mean"], z[f"{k}.basis"],
                                       z[f"{k}.dual"], float(r), float(ln), float(a), float(b),
                                       z[f"{k}.spread"])
                             for k, (r, ln, a, b) in zip(FIT_SIGNALS, meta["fits"],
                                                          strict=True))
                return cls(int(meta["decimate"]), z["scale"], z["center"], z["spread"],
                           z["learned_on"], fits)
        except OSError as error:
            raise ConfigError(f"cannot read: {error}", path=str(path)) from None
        except (KeyError, ValueError, TypeError, AttributeError, IndexError,
                zipfile.BadZipFile, EOFError) as error:
            # a truncated file (a bad zip), a meta that is JSON but not an object: one line
            raise ConfigError(f"malformed discrepancy file ({type(error).__name__}: {error})",
                              path=str(path)) from None


def _components(z: FloatArray, rank: int) -> tuple[FloatArray, FloatArray]:
    """Mean ``(T,)`` and the first ``rank`` principal directions ``(rank, T)`` of ``z``."""
    mean = z.mean(axis=0)
    if rank == 0:
        return mean, np.zeros((0, z.shape[1]))
    _, _, vt = np.linalg.svd(z - mean, full_matrices=False)
    return mean, vt[:rank]


def _train(z: FloatArray, x: FloatArray, rank: int, ridge: float, length: float
           ) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Mean, basis and dual coefficients from residuals ``z (n, T)`` and standardised
    features ``x (n, F)``."""
    mean, basis = _components(z, rank)
    scores = (z - mean) @ basis.T
    dual = np.asarray(np.linalg.solve(kernel(x, x, length) + ridge * np.eye(x.shape[0]),
                                      scores), dtype=np.float64)
    return mean, basis, dual


def _standardise(f: FloatArray) -> tuple[FloatArray, FloatArray]:
    center = np.asarray(f.mean(axis=0), dtype=np.float64)
    sd = f.std(axis=0)
    spread = np.asarray(np.where(sd > 1e-9 * (1.0 + np.abs(center)), sd, 1.0),
                        dtype=np.float64)
    return center, spread


def _drift_fit(z: FloatArray, reg: FloatArray) -> FloatArray:
    """Least-squares coefficients of ``z (n, T)`` on the drift regressors ``(n, 2, T)``."""
    a = reg.transpose(1, 0, 2).reshape(reg.shape[1], -1)
    beta = np.asarray(np.linalg.lstsq(a.T, z.ravel(), rcond=None)[0], dtype=np.float64)
    return beta


def _held_out(z: FloatArray, f: FloatArray, reg: FloatArray | None, rank: int, ridge: float,
              length: float) -> FloatArray:
    """Per time ``(T,)``, the mean square over BITs of predicting each BIT's residual from the
    others' (with the drift term when ``reg`` is given)."""
    n = z.shape[0]
    sq = np.zeros(z.shape[1])
    for i in range(n):
        keep = np.arange(n) != i
        zk, zi = z[keep], z[i]
        if reg is not None:
            beta = _drift_fit(zk, reg[keep])
            zk = zk - np.einsum("j,njt->nt", beta, reg[keep])
            zi = zi - beta @ reg[i]
        c, s = _standardise(f[keep])
        x = (f[keep] - c) / s
        mean, basis, dual = _train(zk, x, rank, ridge, length)
        pred = mean + (kernel(((f[i] - c) / s)[None, :], x, length) @ dual)[0] @ basis
        sq += (zi - pred) ** 2
    out: FloatArray = sq / n
    return out


def _smooth_spread(ms: FloatArray) -> FloatArray:
    """The per-time RMS from per-time mean squares, averaged over :data:`SPREAD_SMOOTH`
    steps and never below 1 (the sensor noise)."""
    kernel_ = np.ones(SPREAD_SMOOTH) / SPREAD_SMOOTH
    padded = np.pad(ms, SPREAD_SMOOTH // 2, mode="edge")
    out: FloatArray = np.maximum(np.sqrt(np.convolve(padded, kernel_, mode="valid")), 1.0)
    return out


def learn(residuals: FloatArray, feats: FloatArray, drift: FloatArray, scale: FloatArray,
          decimate: int) -> Discrepancy:
    """The discrepancy of healthy BITs' residuals ``(n, K, T)`` (record minus identified
    model, channel units) with condition features ``(n, F)`` and bus drift ``(n, T)``;
    ``scale`` ``(K,)`` is the noise unit. :class:`ConfigError` with fewer than
    :data:`MIN_BITS` BITs."""
    n = residuals.shape[0]
    if n < MIN_BITS:
        raise ConfigError(f"{n} BITs: learning a discrepancy needs at least {MIN_BITS}",
                          field="bits")
    z_all = residuals / scale[None, :, None]
    center, spread = _standardise(feats)
    x = (feats - center) / spread
    reg = drift_regressors(feats, drift)
    fits = []
    for k in range(z_all.shape[1]):
        z = z_all[:, k, :]
        none = float(np.sqrt(np.mean(z**2)))
        best: tuple[float, bool, int, float, float, FloatArray] | None = None
        for use_drift in (False, True):
            for rank in range(min(MAX_RANK, n - 2) + 1):
                for ridge in RIDGES if rank else RIDGES[:1]:
                    for length in LENGTHS if rank else LENGTHS[:1]:
                        ms = _held_out(z, feats, reg if use_drift else None, rank, ridge,
                                       length)
                        err = float(np.sqrt(np.mean(ms)))
                        if best is None or err < best[0] * (1.0 - 1e-6):
                            best = (err, use_drift, rank, ridge, length, ms)
        assert best is not None
        err, use_drift, rank, ridge, length, ms = best
        beta = _drift_fit(z, reg) if use_drift else np.zeros(reg.shape[1])
        z = z - np.einsum("j,njt->nt", beta, reg)
        mean, basis, dual = _train(z, x, rank, ridge, length)
        fits.append(SignalFit(beta, mean, basis, dual, ridge, length, none, err,
                              _smooth_spread(ms)))
    return Discrepancy(decimate, np.asarray(scale, dtype=np.float64), center, spread, x,
                       tuple(fits))


def feature_matrix(params: ActuatorParams, bits: Sequence[BitRecord]) -> FloatArray:
    """(n, F) the condition features of ``bits``."""
    return np.stack([features(params, b) for b in bits])


def residuals(params: ActuatorParams, bits: Sequence[BitRecord], decimate: int) -> FloatArray:
    """Record minus the model ``params`` (at the unit's own friction) per BIT, ``(n, K, T)``
    channel units."""
    model = fly(params, [Flight(b) for b in bits], decimate)
    out: FloatArray = recorded(bits, decimate) - model
    return out


def learn_unit(params: ActuatorParams, bits: Sequence[BitRecord], decimate: int
               ) -> Discrepancy:
    """The discrepancy of the identified model ``params`` on the unit's healthy ``bits``.

    The model flies each BIT at the unit's friction (factor 1), as a BIT it has not seen
    would be flown: the grease's flight-to-flight scatter stays in the held-out spread."""
    return learn(residuals(params, bits, decimate), feature_matrix(params, bits),
                 drift_matrix(params, bits, decimate), noise_scale(params, decimate), decimate)


def drift_matrix(params: ActuatorParams, bits: Sequence[BitRecord], decimate: int
                 ) -> FloatArray:
    """(n, T) the bus drift of ``bits``."""
    return np.stack([bus_drift(params, b, decimate) for b in bits])


def correction_for(disc: Discrepancy, params: ActuatorParams, bits: Sequence[BitRecord]
                   ) -> FloatArray:
    """``disc``'s correction for ``bits`` ``(n, K, T)``, their conditions read from their
    own channels."""
    return disc.correction(feature_matrix(params, bits),
                           drift_matrix(params, bits, disc.decimate))


def held_out_discrepancies(disc: Discrepancy, params: ActuatorParams,
                           bits: Sequence[BitRecord]) -> list[Discrepancy]:
    """Per BIT of ``bits`` (those ``disc`` was learned on, in that order), the discrepancy
    learned on the others: each signal's choice (drift term, rank, ridge, kernel) kept as
    ``disc`` made it, its coefficients and its held-out spread recomputed without the BIT.
    What reading a commissioning BIT against a baseline that has not seen it needs (the
    detector's calibration, :mod:`~mapr_daemon.reasoner.commissioning.detector`); the choice
    itself was made with the BIT, a small optimism the threshold's tail fit does not undo."""
    n = len(bits)
    if n != disc.bits or n - 1 < MIN_BITS:
        raise ConfigError(f"{n} BITs for a discrepancy learned on {disc.bits}: holding one "
                          f"out needs the same BITs and at least {MIN_BITS + 1}", field="bits")
    z_all = residuals(params, bits, disc.decimate) / disc.scale[None, :, None]
    feats = feature_matrix(params, bits)
    reg = drift_regressors(feats, drift_matrix(params, bits, disc.decimate))
    out = []
    for i in range(n):
        keep = np.arange(n) != i
        center, spread = _standardise(feats[keep])
        x = (feats[keep] - center) / spread
        fits = []
        for k, f in enumerate(disc.fits):
            z = z_all[keep, k, :]
            use_drift = bool(np.any(f.drift != 0.0))
            ms = _held_out(z, feats[keep], reg[keep] if use_drift else None, f.rank, f.ridge,
                           f.length)
            beta = _drift_fit(z, reg[keep]) if use_drift else np.zeros(reg.shape[1])
            z = z - np.einsum("j,njt->nt", beta, reg[keep])
            mean, basis, dual = _train(z, x, f.rank, f.ridge, f.length)
            fits.append(SignalFit(beta, mean, basis, dual, f.ridge, f.length, f.held_out_none,
                                  float(np.sqrt(np.mean(ms))), _smooth_spread(ms)))
        out.append(Discrepancy(disc.decimate, disc.scale, center, spread, x, tuple(fits)))
    return out
