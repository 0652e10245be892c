/*
 * nnmstop explorer: unpacking the page's data and synthesizing orbits from Fourier coefficients.
 * The same synthesis as nnmstop.fourier (PhaseSynthesis, to_time): a field is
 *   q(theta) = sum_k c_k cos(k theta) + s_k sin(k theta),   theta = omega t,
 * evaluated on the uniform phases theta_j = 2 pi j / m of one period. Runs in the browser (window.Synthesis)
 * and in node (module.exports), so a test can check it against nnmstop.fourier.
 */
(function (root) {
  "use strict";

  const TYPES = {
    f32: Float32Array, f64: Float64Array, i8: Int8Array, u8: Uint8Array, i16: Int16Array, i32: Int32Array,
  };

  function base64Bytes(text) {
    if (typeof atob === "function") {
      const binary = atob(text);
      const bytes = new Uint8Array(binary.length);
      for (let i = 0; i < binary.length; i++) bytes[i] = binary.charCodeAt(i);
      return bytes;
    }
    return new Uint8Array(Buffer.from(text, "base64"));
  }

  /** A packed array {dtype, shape, b64} as {data: TypedArray, shape}. */
  function unpack(packed) {
    const Type = TYPES[packed.dtype];
    if (!Type) throw new Error("unknown packed dtype " + packed.dtype);
    const bytes = base64Bytes(packed.b64);
    const copy = new Uint8Array(bytes.length); // aligned buffer of its own
    copy.set(bytes);
    return { data: new Type(copy.buffer), shape: packed.shape };
  }

  /** Every packed array of a nested object unpacked, in place; returns the object. */
  function unpackAll(value) {
    if (Array.isArray(value)) return value.map(unpackAll);
    if (value && typeof value === "object") {
      if (typeof value.b64 === "string" && value.dtype) return unpack(value);
      for (const key of Object.keys(value)) value[key] = unpackAll(value[key]);
    }
    return value;
  }

  /** Row i of an unpacked 2-D array (a view). */
  function row(array, i) {
    const width = array.shape[1];
    return array.data.subarray(i * width, (i + 1) * width);
  }

  /**
   * Values and d/dtheta of a series on `samples` uniform phases of one period.
   * cos, sin: coefficients of the harmonics `harmonics` (sin may be null: a cosine series).
   */
  function synthesize(cos, sin, harmonics, samples) {
    const m = samples;
    const table = new Float64Array(m);
    const tableSin = new Float64Array(m);
    for (let n = 0; n < m; n++) {
      table[n] = Math.cos((2 * Math.PI * n) / m);
      tableSin[n] = Math.sin((2 * Math.PI * n) / m);
    }
    const values = new Float64Array(m);
    const derivative = new Float64Array(m);
    for (let i = 0; i < harmonics.length; i++) {
      const k = harmonics[i];
      const c = cos[i];
      const s = sin ? sin[i] : 0;
      if (c === 0 && s === 0) continue;
      for (let j = 0; j < m; j++) {
        const n = (k * j) % m; // k theta_j reduced to one period: exact table lookup
        values[j] += c * table[n] + s * tableSin[n];
        derivative[j] += k * (s * table[n] - c * tableSin[n]);
      }
    }
    return { values: values, derivative: derivative };
  }

  /** Times t_j = theta_j / omega of one period. */
  function periodTimes(omega, samples) {
    const t = new Float64Array(samples + 1);
    for (let j = 0; j <= samples; j++) t[j] = (2 * Math.PI * j) / (samples * omega);
    return t;
  }

  /** Piecewise-linear contact force of the non-smooth model, Eq. (4): alpha (|x| - gap) sgn(x) beyond the gap. */
  function piecewiseForce(x, alpha, gap) {
    const out = new Float64Array(x.length);
    for (let j = 0; j < x.length; j++) {
      const excess = Math.abs(x[j]) - gap;
      out[j] = excess > 0 ? alpha * excess * Math.sign(x[j]) : 0;
    }
    return out;
  }

  const api = { unpack, unpackAll, row, synthesize, periodTimes, piecewiseForce };
  if (typeof module === "object" && module.exports) module.exports = api;
  else root.Synthesis = api;
})(typeof self !== "undefined" ? self : this);
