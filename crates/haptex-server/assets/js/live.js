// The server's live output (haptex serve --live, docs/live.md): the
// design the strip plays and every position it takes go over a WebSocket
// to the server's audio device, whose figures (position, voltage played,
// latency) are shown as they come.

import { $ } from './dom.js';
import { api } from './api.js';
import { played } from './check.js';
import { fmt } from './format.js';
import { state } from './state.js';

/**
 * The server's live output (haptex serve --live, docs/live.md): while
 * live, the design the strip plays is sent over a WebSocket, and every
 * position the strip takes (pointer, finger or keyboard) is sent as a
 * `t_s,x_mm` line stamped with the event's own time; the server plays it
 * on its audio device and answers the figures (position, voltage played,
 * latency) every 100 ms. Lifting the finger sends `lift`.
 */
export const live = {
  info: null,
  socket: null,
  sent: null,
  /** Shows the panel when the server has a live output. */
  async setup() {
    let answer;
    try {
      answer = await (await api('/api/live')).json();
    } catch (error) {
      return; // an older server: no live mode
    }
    if (!answer.available) return;
    this.info = answer.output;
    const o = answer.output;
    $('live-output').textContent = `${o.device}, ${o.sample_rate_hz} Hz, U_max ${o.u_max_v} V, ` +
      `${fmt(o.volts_per_full_scale)} V per full scale` + (o.a_max_um ? `, ultrasonic a_max ${o.a_max_um} µm` : '');
    $('live-box').hidden = false;
    $('live-toggle').addEventListener('click', () => (this.socket ? this.stop() : this.start()));
  },
  start() {
    const scheme = location.protocol === 'https:' ? 'wss' : 'ws';
    const socket = new WebSocket(`${scheme}://${location.host}/api/live/ws`);
    this.socket = socket;
    this.sent = null;
    this.show('connecting…');
    $('live-toggle').textContent = 'Stop live';
    $('live-toggle').setAttribute('aria-pressed', 'true');
    socket.addEventListener('open', () => this.follow());
    socket.addEventListener('message', (e) => this.receive(e.data));
    socket.addEventListener('close', () => { if (this.socket === socket) this.off(); });
  },
  stop() {
    if (!this.socket) return;
    if (this.socket.readyState === WebSocket.OPEN) this.socket.send(JSON.stringify({ stop: true }));
    const socket = this.socket;
    setTimeout(() => socket.close(), 300);
    this.show('stopped: faded to 0 V');
    this.off();
  },
  /** The panel as without a connection (the socket stopped or lost). */
  off() {
    this.socket = null;
    this.sent = null;
    $('live-toggle').textContent = 'Go live';
    $('live-toggle').setAttribute('aria-pressed', 'false');
    $('live-box').dataset.live = 'off';
  },
  /** Sends the design the strip plays, when it is not the one sent last. */
  follow() {
    if (!this.socket || this.socket.readyState !== WebSocket.OPEN) return;
    const v = state.voltage ? played() : null;
    if (v === this.sent) return;
    this.sent = v;
    if (!v) {
      this.socket.send(JSON.stringify({ stop: true }));
      return;
    }
    const design = { x_mm: v.x_mm };
    if (v.voltage_v) design.voltage_v = v.voltage_v;
    if (v.amplitude_um) design.amplitude_um = v.amplitude_um;
    this.socket.send(JSON.stringify({ design }));
    this.show('opening the output…');
  },
  /** A position of the strip while touched, at the event's time `timeStamp` (ms, the page's clock). */
  touch(x, timeStamp) {
    if (!this.socket || this.socket.readyState !== WebSocket.OPEN || !this.sent) return;
    this.socket.send(`${(timeStamp / 1000).toFixed(6)},${x}`);
  },
  lift() {
    if (this.socket && this.socket.readyState === WebSocket.OPEN && this.sent) this.socket.send('lift');
  },
  receive(text) {
    let m;
    try { m = JSON.parse(text); } catch (error) { return; }
    const box = $('live-box');
    if (m.error) {
      this.show(`refused: ${m.error}`, true);
      box.dataset.error = m.error;
      return;
    }
    if (m.opened) {
      box.dataset.live = 'on';
      delete box.dataset.error;
      this.show(`live on ${m.opened.output.device}: touch the strip (peak at most ${m.opened.peak_bound_v.toFixed(1)} V)`);
    } else if (m.status) {
      const f = m.status;
      box.dataset.xMm = String(f.x_mm);
      box.dataset.outputV = String(f.output_v);
      box.dataset.events = String(f.events);
      box.dataset.touchToOutputMs = String(f.touch_to_output_max_ms);
      const latency = f.events ? `touch → sample ${f.render_latency_max_ms.toFixed(2)} ms (max), device buffer ` +
        `${f.output_latency_max_ms.toFixed(2)} ms, end to end ≤ ${f.touch_to_output_max_ms.toFixed(2)} ms` : 'no touch yet';
      this.show(`live: x = ${f.x_mm.toFixed(3)} mm, U = ${f.output_v.toFixed(1)} V RMS played` +
        (f.amplitude_um ? `, a = ${f.amplitude_um.toFixed(3)} µm` : '') + ` · ${latency} · ${f.events} touches` +
        (f.underruns ? ` · ${f.underruns} underruns` : ''));
    } else if (m.closed !== undefined) {
      box.dataset.live = 'off';
    }
  },
  show(text, isError = false) {
    const readout = $('live-readout');
    readout.textContent = text;
    readout.classList.toggle('error', isError);
  },
};
