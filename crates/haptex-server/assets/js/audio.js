// The browser's audio output of the haptex pages (the main page's feel
// strip, the map view): Web Audio, a sine at the carrier frequency whose
// amplitude follows U. Full scale (sample 1.0) stands for sqrt(2) U_max
// at the amplifier, so an RMS envelope U gives a peak of sqrt(2) U:
// level = U / U_max.

/**
 * An output that is silent until started: `carrierHz()` gives the
 * carrier's frequency when it starts, `complain(text)` is told when the
 * browser has no Web Audio.
 */
export function createAudio(carrierHz, complain) {
  return {
    context: null,
    oscillator: null,
    gain: null,
    /** The last level asked for (0 .. 1), whether or not the output is on. */
    level: 0,
    start() {
      const Context = window.AudioContext || window.webkitAudioContext;
      if (!Context) { complain('This browser has no Web Audio.'); return; }
      this.context = new Context();
      this.oscillator = this.context.createOscillator();
      this.oscillator.type = 'sine';
      this.oscillator.frequency.value = carrierHz();
      this.gain = this.context.createGain();
      this.gain.gain.value = 0;
      this.oscillator.connect(this.gain).connect(this.context.destination);
      this.oscillator.start();
    },
    stop() {
      if (this.context) this.context.close();
      this.context = null;
      this.oscillator = null;
      this.gain = null;
    },
    /** The level, 0 .. 1 of full scale (U / U_max), reached in about 4 ms. */
    set(level) {
      const value = Math.min(1, Math.max(0, level));
      this.level = value;
      if (!this.gain) return;
      this.gain.gain.setTargetAtTime(value, this.context.currentTime, 0.004);
    },
    setFrequency(f) {
      if (this.oscillator) this.oscillator.frequency.setTargetAtTime(f, this.context.currentTime, 0.01);
    },
  };
}
