"""The AHRS of :mod:`dualpose.estimation.ahrs` one sample at a time (streaming), with a savable state.

:class:`AhrsStream` runs the same compiled per-sample step as :func:`~dualpose.estimation.ahrs.estimate_orientation`
(``step`` in ``src/native/estimation/ahrs_run.cpp``; the whole-recording loop is a loop over it) and the same
compiled rest-period outputs (``rest_run``), so a stream fed sample by sample, a stream fed in blocks
(:meth:`AhrsStream.update_batch`) and the batch estimator give the same orientations and biases to the last bit,
provided they use the same settings -- including the default online magnetometer time offset -- and the batch
estimator's non-causal options are off (``mag_time_offset="estimate"``, ``mag_calibration``).  Every output is causal
and returned at its own sample.

The whole filter state -- orientation, bias, covariance, the field window's ring buffers and sums, the accelerometer
low-pass state, the accumulated corrections, gate counters, adaptive-noise estimates, the rest detector's window and
statistics -- lives in one ``numpy.uint8`` buffer with a header (magic number, layout version, size;
``AhrsStream.LAYOUT_VERSION``). Saving the stream is a copy of that buffer (:meth:`AhrsStream.state_dict`); restoring it
(:meth:`AhrsStream.from_state`) continues exactly where the saved stream stopped. A buffer of another layout version or
size is refused with a ValueError.
"""

from __future__ import annotations

import math
from dataclasses import asdict
from typing import Any

import numpy as np
from numpy.typing import NDArray

from dualpose import _native
from dualpose.estimation._stream import GapWatch, sample_block, saved_buffer, saved_quaternion, saved_rate_stamps, vec3
from dualpose.estimation.ahrs.config import (
    AhrsConfig,
    AhrsNoise,
    RestStatistics,
    _check_config,
    _rest_length,
    check_field_samples,
    check_mag_time_offset,
    filter_setup,
    rest_statistics,
)
from dualpose.types import _inputs

__all__ = ["AhrsStream"]


def _buffers(size: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Empty rest-sample buffers: t (size,), gyro, accel, mag (size, 3)."""
    return np.zeros(size), np.zeros((size, 3)), np.zeros((size, 3)), np.zeros((size, 3))


class AhrsStream:
    """The AHRS (gyroscope, accelerometer, optional magnetometer) updated one sample at a time.

    The model, the defaults and the initialisation are those of
    :func:`~dualpose.estimation.ahrs.estimate_orientation` (its docstring and docs/broad.md describe them); the
    keyword arguments have the same meaning.  Differences, all because a stream cannot look ahead:

    * the magnetometer–gyroscope time offset is estimated online (the default ``mag_time_offset="online"``, inside
      the compiled state) or fixed; the batch estimator's whole-recording estimate (``"estimate"``) and its
      magnetometer self-calibration need the future and are not available: the stream equals
      ``estimate_orientation(..., mag_time_offset=<the same>, mag_calibration=None)`` sample for sample, bit for bit;
    * initialisation from a rest period: with ``rest`` given (e.g. :func:`~dualpose.estimation.ahrs.rest_statistics`
      of an earlier recording) the filter starts at the first sample.  Otherwise, inside the first ``n_rest``
      samples the output is the orientation of the running mean specific force and field so far (and the running
      mean rate as :attr:`gyro_bias`); at the last of them the rest statistics are computed, the filter is
      initialised and run over the rest samples, and its output is returned.  Every output comes at its own
      sample.  ``n_rest=0``: start at the first sample from its own directions (as the batch estimator with
      ``n_rest=0``);
    * the sampling is uniform at ``rate`` (the filter's step is ``1 / rate``, as in the batch estimator); the time
      stamps ``t`` are only checked to increase strictly.

    Parameters
    ----------
    rate : float
        Sampling rate, Hz.
    use_mag : bool
        9D (True) or 6D (False).
    n_rest : int, optional
        Leading samples at rest (default: one second, ``round(rate)``, or 0 when that is below 10).  Ignored when
        ``rest`` is given.
    rest : RestStatistics, optional
        Rest statistics to start from (no buffering).
    config : AhrsConfig, optional
        Tuning, as in :func:`~dualpose.estimation.ahrs.estimate_orientation` (default :class:`AhrsConfig`).
    mag_time_offset : "online" or float
        Magnetometer lag behind the gyroscope: estimated online (default) or this many seconds (0: none), compensated
        causally as in :func:`~dualpose.estimation.ahrs.estimate_orientation`.  Ignored in 6D.

    Examples
    --------
    >>> s = AhrsStream(100.0, use_mag=False, n_rest=0)
    >>> s.update_imu(0.0, [0.0, 0.0, 0.0], [0.0, 0.0, 9.81]).shape
    (4,)
    """

    #: version of the saved state's byte layout (``STREAM_VERSION`` in ``src/native/estimation/ahrs_run.hpp``)
    LAYOUT_VERSION: int = _native.AHRS_STREAM_VERSION

    def __init__(
        self,
        rate: float,
        *,
        use_mag: bool = True,
        n_rest: int | None = None,
        rest: RestStatistics | None = None,
        config: AhrsConfig | None = None,
        mag_time_offset: str | float = "online",
    ) -> None:
        rate = _inputs.check_rate(rate)
        n_rest = _inputs.check_rest_samples(_rest_length(rate, 0 if rest is not None else n_rest), rate)
        self._settings = _check_config(config)
        lag = check_mag_time_offset(mag_time_offset, ("online",))
        assert not isinstance(lag, str)  # only "online" is allowed, which is None
        self._lag = lag
        self._config = dict(rate=float(rate), use_mag=bool(use_mag), n_rest=int(n_rest), rest=rest,
                            mag_time_offset="online" if self._lag is None else self._lag)
        self._rate = float(rate)
        self._use_mag = bool(use_mag)
        self._n_rest = int(n_rest)
        self._rest = rest
        self._state: np.ndarray | None = None
        # the rest samples buffered until the rest period is complete: t (N,), gyro, accel, mag (N, 3), N <= n_rest
        # (grown as samples come: a long rest period at a high rate allocates only what it receives)
        self._pending = _buffers(min(max(self._n_rest, 1), 1024))
        self._n_pending = 0
        self._t = -math.inf
        self._samples = 0
        #: the IMU gaps :meth:`update_imu` saw (longer than five sample periods ``1 / rate``): warned about
        #: (:class:`~dualpose.types.recording.RecordingWarning`) and counted; see :attr:`doubts`
        self.gap_watch = GapWatch(1.0 / self._rate, rate_name="rate")
        self._rest_sums = np.zeros(10)  # running sums of gyro, accel, mag and the count inside the rest period
        self._rest_out = (np.full(4, np.nan), np.full(3, np.nan))  # the last rest-period output (quat, bias)
        if rest is not None:
            self._start(None, None)

    # ---- set-up -------------------------------------------------------------------------------------------------

    def _start(self, first_acc: np.ndarray | None, first_mag: np.ndarray | None) -> None:
        setup = filter_setup(self._rate, self._rest, first_acc, first_mag, use_mag=self._use_mag, config=self._settings,
                             mag_time_offset=self._lag, rest_skip=self._n_rest)
        self._state = _native.ahrs_stream_new(
            setup.params, setup.Ha, setup.Hm, 1.0 / self._rate, setup.q, setup.b, setup.P
        )

    def _finish_rest(self) -> tuple[np.ndarray, np.ndarray]:
        """Initialise from the buffered rest samples and filter them; the filter's output at the last one."""
        _, g, a, m = self._pending_arrays()
        self._n_pending = 0
        if self._n_rest:
            self._rest = rest_statistics(g, a, m if self._use_mag else None, self._rate, self._n_rest)
            self._start(None, None)
        else:
            self._start(a[0], m[0])
        out_q, out_b = np.empty((len(g), 4)), np.empty((len(g), 3))
        _native.ahrs_stream_run(self._state, g, a, m, out_q, out_b)
        return out_q[-1], out_b[-1]

    def _rest_outputs(self, g: np.ndarray, a: np.ndarray, m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The causal outputs of rest samples before the last one: running means (``ahrs_rest_run``)."""
        out_q, out_b = np.empty((len(g), 4)), np.empty((len(g), 3))
        _native.ahrs_rest_run(g, a, m, self._use_mag, self._rest_sums, out_q, out_b)
        if len(g):
            self._rest_out = (out_q[-1].copy(), out_b[-1].copy())
        return out_q, out_b

    # ---- updates ------------------------------------------------------------------------------------------------

    def update_imu(self, t: float, gyro: Any, accel: Any, mag: Any = None) -> np.ndarray:
        """Filter one sample and return the orientation after it.

        Parameters
        ----------
        t : float
            Time stamp, s (must increase strictly; the filter's step is ``1 / rate``).
        gyro : array_like, shape (3,)
            Angular rate, rad/s, IMU axes.
        accel : array_like, shape (3,)
            Specific force, m/s², IMU axes.
        mag : array_like, shape (3,), optional
            Magnetic field (µT), IMU axes, calibrated and time-aligned; required in 9D, ignored in 6D.

        Returns
        -------
        ndarray, shape (4,)
            Orientation xyzw, IMU → earth (ENU), after this sample's updates (inside the rest period: from the
            running mean directions so far).
        """
        g, a = vec3(gyro, "gyro"), vec3(accel, "accel")  # finite and within the IMU limits (docs/refusals.md)
        m = vec3(mag, "mag") if mag is not None else None
        self._check_sample(t, mag)
        if self._use_mag and m is not None and not float(m @ m) > 0.0:  # a zero field has no direction
            check_field_samples(m[None], single=True)  # the shared rule's message (docs/refusals.md)
        w = self.gap_watch  # GapWatch.see, inlined: a gap longer than five sample periods is reported
        if t - w.last > w.limit:
            w.note(t)
        w.last = t
        if self._state is not None:
            q: np.ndarray = _native.ahrs_stream_step(self._state, g, a, m)
            self._t = t
            self._samples += 1
            return q
        self._check_rest_force(a[None], single=True)
        k = self._n_pending
        self._reserve(k + 1)
        pt, pg, pa, pm = self._pending
        pg[k], pa[k] = g, a
        pm[k] = m if m is not None else 0.0
        pt[k] = t
        self._t = t
        self._samples += 1
        self._n_pending += 1
        if self._n_pending < max(self._n_rest, 1):
            first: NDArray[np.float64] = self._rest_outputs(pg[k : k + 1], pa[k : k + 1], pm[k : k + 1])[0][0]
            return first
        return np.copy(self._finish_rest()[0], order="C")

    def _check_rest_force(self, a: np.ndarray, single: bool = False) -> None:
        """Refuse rest samples ``a`` (k, 3) after which the running mean specific force is zero (it has no direction
        to start from), before any change to the stream."""
        c = self._rest_sums[3:6] + np.cumsum(a, axis=0)
        zero = ~(np.abs(c).max(axis=1) > 0) if len(c) else np.zeros(0, bool)
        if zero.any():
            k = int(np.argmax(zero))
            at = "" if single else f": row {k}"
            raise ValueError(f"accel{at}: the mean specific force of the rest period so far is zero: no vertical to "
                             "start from (at rest an accelerometer reads about 9.81 m/s²)")  # fmt: skip

    def _reserve(self, k: int) -> None:
        """Room for ``k`` buffered rest samples (doubling, at most ``n_rest``)."""
        size = len(self._pending[0])
        if k > size:
            grown = _buffers(min(max(k, 2 * size), max(self._n_rest, 1)))
            for new, old in zip(grown, self._pending, strict=True):
                new[:size] = old
            self._pending = grown

    def _check_sample(self, t: float, mag: Any) -> None:
        if not (math.isfinite(t) and t > self._t):
            raise ValueError(f"t must be finite and increase strictly: got {t} after {self._t}")
        if mag is None and self._use_mag:
            raise ValueError("mag is required in 9D (use_mag=True); pass use_mag=False for 6D")

    def update_batch(self, t: Any, gyro: Any, accel: Any, mag: Any = None) -> tuple[np.ndarray, np.ndarray]:
        """Filter a block of samples (the same compiled step as :meth:`update_imu`, without a Python call per sample).

        Parameters
        ----------
        t : array_like, shape (n,)
            Time stamps, s, strictly increasing and after the last sample filtered.
        gyro, accel, mag : array_like, shape (n, 3)
            As in :meth:`update_imu` (``mag`` required in 9D).

        Returns
        -------
        quat : ndarray, shape (n, 4)
            Orientation after each sample, xyzw, IMU → earth (as :meth:`update_imu` returns them).
        gyro_bias : ndarray, shape (n, 3)
            Gyroscope bias after each sample, rad/s.
        """
        t = np.ascontiguousarray(t, dtype=np.float64).reshape(-1)
        n = t.shape[0]
        g = sample_block(gyro, "gyro", n)
        a = sample_block(accel, "accel", n)
        if mag is None and self._use_mag:
            raise ValueError("mag is required in 9D (use_mag=True); pass use_mag=False for 6D")
        m = sample_block(mag, "mag", n) if mag is not None else np.zeros((n, 3))
        if self._use_mag:
            check_field_samples(m)
        _inputs.sample_times(t, "t", self._t)  # finite, strictly increasing, after the last sample filtered
        out_q = np.full((n, 4), np.nan)
        out_b = np.full((n, 3), np.nan)
        i = 0
        if self._state is None:
            need = max(self._n_rest, 1) - self._n_pending
            i = min(n, need)
            self._check_rest_force(a[:i])
            k = self._n_pending
            self._reserve(k + i)
            for buf, x in zip(self._pending, (t, g, a, m), strict=True):
                buf[k : k + i] = x[:i]
            self._n_pending += i
            j = i - 1 if i == need else i  # samples before the one that completes the rest period
            out_q[:j], out_b[:j] = self._rest_outputs(g[:j], a[:j], m[:j])
            if i == need:
                out_q[j], out_b[j] = self._finish_rest()
        if i < n:
            _native.ahrs_stream_run(self._state, g[i:], a[i:], m[i:], out_q[i:], out_b[i:])
        if n:
            self._t = float(t[-1])
            self._samples += n
        return out_q, out_b

    # ---- state --------------------------------------------------------------------------------------------------

    @property
    def rate(self) -> float:
        """The sampling rate the filter steps at, Hz."""
        return self._rate

    @property
    def doubts(self) -> list[_inputs.Doubt]:
        """What :meth:`update_imu` doubted about its input, each also warned: the first IMU gaps (``"imu_gap"``;
        ``gap_watch.count`` counts them all) and, after the first 200 samples, a stated rate the stamps contradict
        (``"imu_rate_mismatch"``; ``GapWatch`` of ``dualpose.estimation._stream``).  Not part of the saved state."""
        return list(self.gap_watch.doubts)

    @property
    def ready(self) -> bool:
        """Whether the filter is initialised (the rest period, if any, is complete)."""
        return self._state is not None

    @property
    def samples(self) -> int:
        """Samples filtered or buffered so far."""
        return self._samples

    @property
    def rest(self) -> RestStatistics | None:
        """The rest statistics the filter started from (None before initialisation or without a rest period)."""
        return self._rest

    def _get(self, k: int) -> np.ndarray:
        if self._state is None:
            if k < 2:
                return np.copy(self._rest_out[k], order="C")
            return np.full((4, 3, 36, _native.AHRS_N_STATS)[k], np.nan)
        out: NDArray[np.float64] = _native.ahrs_stream_get(self._state)[k]
        return out

    @property
    def quat(self) -> np.ndarray:
        """Current orientation, xyzw, IMU → earth (ENU), shape (4,) (inside the rest period: the running-mean
        orientation; NaN before the first sample)."""
        return self._get(0)

    @property
    def gyro_bias(self) -> np.ndarray:
        """Current gyroscope bias, rad/s, shape (3,) (inside the rest period: the running mean rate)."""
        return self._get(1)

    @property
    def mag_time_offset(self) -> float:
        """The magnetometer lag τ̂ the filter currently compensates, s (online: the estimate so far; 0 in 6D;
        NaN before initialisation)."""
        return float(self._get(3)[_native.AHRS_S_MAG_LAG])

    @property
    def rest_samples(self) -> int:
        """Samples the rest detector has flagged as at rest so far (docs/broad.md, "Rest detector and bias update";
        0 before initialisation)."""
        return int(np.nan_to_num(self._get(3)[_native.AHRS_S_REST_SAMPLES]))

    @property
    def covariance(self) -> np.ndarray:
        """Current error covariance of ``[δθ (earth frame), δb]``, shape (6, 6)."""
        return self._get(2).reshape(6, 6)

    def state_dict(self) -> dict[str, Any]:
        """Everything needed to continue this stream elsewhere (:meth:`from_state`), as copies.

        Returns
        -------
        dict
            ``version`` (:attr:`LAYOUT_VERSION`), ``state`` (the filter's ``numpy.uint8`` buffer, None before
            initialisation), ``pending`` (buffered rest samples: ``t`` (k,), ``gyro``, ``accel``, ``mag`` (k, 3)),
            ``rest_sums`` (running sums of the rest-period outputs), ``t`` (last time stamp), ``samples``,
            ``rest_output`` (the last rest-period output), ``config`` (the constructor's arguments, with
            ``config`` and ``rest`` as plain dicts) and ``imu_rate_stamps`` (the first stamps, kept until the
            stated rate is compared with them; None after).
        """
        c: dict[str, Any] = dict(self._config)
        c["config"] = self._settings.as_dict()
        c["rest"] = self._rest_dict(c["rest"])
        pt, pg, pa, pm = self._pending_arrays()
        return _inputs.seal({
            "version": self.LAYOUT_VERSION,
            "state": None if self._state is None else self._state.copy(),
            "pending": {"t": pt, "gyro": pg, "accel": pa, "mag": pm},
            "t": self._t,
            "samples": self._samples,
            "rest_statistics": self._rest_dict(self._rest),
            "rest_sums": self._rest_sums.copy(),
            "rest_output": {"quat": self._rest_out[0].copy(), "gyro_bias": self._rest_out[1].copy()},
            "config": c,
            "imu_rate_stamps": self.gap_watch.saved_stamps(),
        })  # fmt: skip

    def _pending_arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The buffered rest samples as arrays t (k,), gyro, accel, mag (k, 3)."""
        k = self._n_pending
        pt, pg, pa, pm = (np.copy(x[:k], order="C") for x in self._pending)
        return pt, pg, pa, pm

    @staticmethod
    def _rest_dict(rest: RestStatistics | None) -> dict[str, Any] | None:
        if rest is None:
            return None
        d = {f: getattr(rest, f) for f in ("samples", "gyroscope_bias", "specific_force", "magnetic_field")}
        return {**d, "noise": asdict(rest.noise)}

    @staticmethod
    def _rest_from(d: dict[str, Any] | None) -> RestStatistics | None:
        if d is None:
            return None
        noise = AhrsNoise(**d["noise"])
        m = np.array(d["magnetic_field"], dtype=np.float64).reshape(3)
        if not all((math.isfinite(v) and v >= 0) or (k.startswith("magnetometer") and math.isnan(v))
                   for k, v in asdict(noise).items()):  # 6D: no magnetometer noise (NaN)
            raise ValueError(f"state: rest statistics noise must be finite and >= 0; got {asdict(noise)}")
        return RestStatistics(
            samples=int(d["samples"]),
            gyroscope_bias=_inputs.finite_vector(d["gyroscope_bias"], "state: rest gyroscope_bias", 3,
                                                 _inputs.IMU_LIMITS["gyro"]),
            specific_force=_inputs.finite_vector(d["specific_force"], "state: rest specific_force", 3,
                                                 _inputs.IMU_LIMITS["accel"]),
            magnetic_field=m if np.isnan(m).all() else _inputs.finite_vector(m, "state: rest magnetic_field", 3,
                                                                             _inputs.IMU_LIMITS["mag"]),  # 6D: NaN
            noise=noise,
        )  # fmt: skip

    @classmethod
    def from_state(cls, state: dict[str, Any]) -> AhrsStream:
        """A stream that continues exactly where the one that wrote ``state`` (:meth:`state_dict`) stopped.

        Parameters
        ----------
        state : dict
            The output of :meth:`state_dict` (possibly after a round trip through ``pickle`` or ``numpy.savez``).

        Returns
        -------
        AhrsStream

        Raises
        ------
        ValueError
            Naming ``state`` when it is not a saved AHRS stream, has another layout version, or its buffer has the
            wrong size.
        """
        try:
            version, config = int(state["version"]), dict(state["config"])
        except (TypeError, KeyError, ValueError) as exc:
            raise ValueError(f"state is not a saved AhrsStream (state_dict()): {exc!r}") from None
        if version != cls.LAYOUT_VERSION:
            raise ValueError(f"state has AHRS stream layout version {version}; this build reads {cls.LAYOUT_VERSION}")
        try:
            return cls._restore(state, config)
        except (TypeError, KeyError, AttributeError, OverflowError) as exc:
            raise ValueError(f"state is not a saved AhrsStream (state_dict()): {exc!r}") from None

    @classmethod
    def _restore(cls, state: dict[str, Any], config: dict[str, Any]) -> AhrsStream:
        """:meth:`from_state` after the version and checksum checks; every value checked (docs/refusals.md)."""
        buf = state["state"]
        if buf is not None:
            buf = saved_buffer(buf, _native.ahrs_stream_check, "state")
        _inputs.check_seal(state)
        if buf is not None:
            q, b, P, _ = _native.ahrs_stream_get(buf)
            if not (np.isfinite(q).all() and np.isfinite(b).all()):
                raise ValueError("state['state']: the saved filter state is not finite (a corrupted or altered buffer)")
            saved_quaternion(q, "state['state']")
            _inputs.covariance_matrix(np.reshape(P, (6, 6)), "state['state'] covariance", 6)
        config["config"] = AhrsConfig.from_dict(config["config"])
        config["rest"] = cls._rest_from(config["rest"])
        rest0 = config["rest"]
        config["rest"] = None  # do not start a fresh filter: the saved one is restored below
        out = cls(**config)
        out._config["rest"] = rest0
        out._rest = cls._rest_from(state["rest_statistics"])
        out._state = buf
        pend = state["pending"]
        pt = _inputs.sample_times(pend["t"], "state['pending']['t']")
        k = pt.size
        blk = [_inputs.imu_rows(np.reshape(pend[f], (-1, 3)), f"state['pending'][{f!r}]", f, k)
               for f in ("gyro", "accel", "mag")]  # fmt: skip
        if k and (out._state is not None or k >= max(out._n_rest, 1)):
            raise ValueError(f"state['pending'] holds {k} rest samples; the saved stream buffers fewer than "
                             f"{max(out._n_rest, 1)} and none once started")  # fmt: skip
        out._reserve(k)
        for buf, x in zip(out._pending, (pt, *blk), strict=True):
            buf[:k] = x
        out._n_pending = k
        out._t = float(state["t"])
        out._samples = int(state["samples"])
        if not ((math.isfinite(out._t) or (out._t == -math.inf and out._samples == 0)) and out._samples >= k
                and (not k or out._t >= pt[-1])):  # fmt: skip
            raise ValueError(f"state: t = {out._t!r} and samples = {out._samples!r} are not a saved stream's (finite, "
                             "at least the buffered samples)")  # fmt: skip
        out._rest_sums = _inputs.finite_vector(np.reshape(state["rest_sums"], -1), "state['rest_sums']", 10)
        ro = state["rest_output"]
        rq, rb = np.array(ro["quat"], dtype=np.float64).reshape(4), np.array(ro["gyro_bias"], np.float64).reshape(3)
        for v, name in ((rq, "quat"), (rb, "gyro_bias")):
            if not (np.isfinite(v).all() or np.isnan(v).all()):
                raise ValueError(f"state['rest_output'][{name!r}] must be finite (or all NaN before any output)")
        out._rest_out = (rq, rb)
        out.gap_watch.start_after(out._t, saved_rate_stamps(state.get("imu_rate_stamps"), out._t,
                                                            "state['imu_rate_stamps']"))  # fmt: skip
        return out
