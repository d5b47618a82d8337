// rio teleop.webxr page: streams a controller's, hand's or phone's pose to the robot over a WebSocket.
// Plain JavaScript, no build step. Every input source (WebXR frames, phone orientation, on-screen buttons,
// and the test hook window.__rioInjectPose) goes through submit(): one message path to the robot.
// teleop.webxr_hands (config "hands": true): each XR frame's tracked hands (wrist + 25 joints) also go out
// as `hands` messages through submitHands(), which the test hook window.__rioInjectHands uses too.
'use strict';
(() => {
  const $ = (id) => document.getElementById(id);
  const S = {
    ws: null, cfg: { hand: 'right', stale_s: 0.25 }, seq: 0, sample: null, lastSent: 0,
    clutchBtn: false, gripBtn: false, mode: false, done: false, jog: [0, 0, 0], virt: [0, 0, 0],
    orient: null, xr: null, phone: false, pings: new Map(), pingId: 0, rtt: null, status: null, sent: 0, source: '-',
    hands: null, handsBudget: 1, handsT: 0, handsLast: 0, handsSent: 0, handsSeen: null,
  };
  const KEEPALIVE_MS = 40; // resend the newest sample this often when nothing new came (the node's watchdog)

  // ---- link ----------------------------------------------------------------------------------------
  function connect() {
    const ws = new WebSocket(`wss://${location.host}/ws`);
    S.ws = ws;
    ws.onopen = () => { send({ type: 'hello', client: navigator.userAgent.slice(0, 200) }); link('connected', true); };
    ws.onclose = (ev) => { link(`disconnected (${ev.code}${ev.reason ? ' ' + ev.reason : ''}); retrying`, false);
      S.ws = null; setTimeout(connect, 1000); };
    ws.onmessage = (ev) => {
      let m; try { m = JSON.parse(ev.data); } catch (e) { return; }
      if (m.type === 'config') { S.cfg = m; $('fp').textContent = m.fingerprint; handsMode(!!m.hands); }
      else if (m.type === 'pong') {
        const p = S.pings.get(m.id); S.pings.delete(m.id);
        if (p) { const now = performance.now(); S.rtt = now - p.t;
          if (p.resolve) p.resolve({ rtt_ms: S.rtt, t_send: p.t, t_recv: now, server_t: m.server_t }); }
      } else if (m.type === 'status') { S.status = m; showStatus(m); }
      else if (m.type === 'error') { $('msg').textContent = 'robot: ' + m.message; }
    };
  }
  function send(obj) {
    if (S.ws && S.ws.readyState === WebSocket.OPEN) { S.ws.send(JSON.stringify(obj)); return true; }
    return false;
  }
  function ping() {
    return new Promise((resolve) => {
      const id = ++S.pingId, t = performance.now();
      S.pings.set(id, { t, resolve });
      if (!send({ type: 'ping', id, t })) { S.pings.delete(id); resolve(null); }
    });
  }
  setInterval(() => { ping(); if (S.pings.size > 20) S.pings.clear(); }, 500);

  // ---- the one message path ------------------------------------------------------------------------
  // sample: {pose: {p: [x, y, z], q: [x, y, z, w]} | null, clutch: bool, trigger: 0..1, source: string}
  function submit(sample) {
    S.sample = sample;
    S.source = sample.source;
    const msg = { type: 'input', seq: ++S.seq, t: performance.now(), source: sample.source,
      pose: sample.pose, clutch: !!sample.clutch, trigger: Math.min(1, Math.max(0, +sample.trigger || 0)),
      mode: S.mode, done: S.done };
    if (send(msg)) { S.mode = false; S.done = false; S.sent++; }
    S.lastSent = performance.now();
    return msg;
  }
  // nothing tracked (no XR session, phone still): keep the link fresh with what the buttons say
  setInterval(() => {
    if (!S.xr && S.hands && S.hands.source === 'test' && performance.now() - S.handsLast >= KEEPALIVE_MS) {
      submitHands(S.hands, 'test'); // injected hands are held still, like an injected pose
    }
    if (performance.now() - S.lastSent < KEEPALIVE_MS) return;
    if (S.xr) return; // an XR session streams every frame itself
    if (S.phone) submit(phoneSample(S.sample || {}));
    else if (S.sample && S.sample.source === 'test') submit(S.sample); // an injected pose is held still
    else submit({ pose: null, clutch: S.clutchBtn, trigger: S.gripBtn ? 1 : 0, source: 'buttons' });
  }, KEEPALIVE_MS / 2);

  // ---- hands (teleop.webxr_hands): both hands' 25 joints, one `hands` message per XR frame --------------
  // hands: {left, right}, each null (not tracked) or {j: 25 x [x, y, z] in JOINTS order, q: wrist [x, y, z, w]}
  // in the reference space. At most cfg.hands_hz messages a second on average (a frame over budget is
  // skipped); positions rounded to 0.1 mm. A hand the node would refuse (not finite, too far) goes as null.
  const JOINTS = ['wrist', 'thumb-metacarpal', 'thumb-phalanx-proximal', 'thumb-phalanx-distal', 'thumb-tip'];
  for (const f of ['index-finger', 'middle-finger', 'ring-finger', 'pinky-finger']) {
    for (const part of ['metacarpal', 'phalanx-proximal', 'phalanx-intermediate', 'phalanx-distal', 'tip']) JOINTS.push(`${f}-${part}`);
  }
  const round = (x, k) => Math.round(x * k) / k;
  function handMsg(h) {
    if (!h || !Array.isArray(h.j) || h.j.length !== JOINTS.length || !Array.isArray(h.q) || h.q.length !== 4) return null;
    const j = h.j.map((p) => [0, 1, 2].map((i) => round(+p[i], 1e4)));
    const q = h.q.map((x) => round(+x, 1e5));
    const maxPos = +S.cfg.max_pos_m || 20, span = +S.cfg.max_hand_span_m || 0.5;
    const ok = j.every((p) => p.every((x) => Number.isFinite(x) && Math.abs(x) <= maxPos)
      && Math.hypot(p[0] - j[0][0], p[1] - j[0][1], p[2] - j[0][2]) <= span)
      && q.every(Number.isFinite) && Math.abs(Math.hypot(...q) - 1) < 0.1;
    return ok ? { j, q } : null;
  }
  function submitHands(hands, source, force = false) {
    S.hands = { left: (hands && hands.left) || null, right: (hands && hands.right) || null, source };
    const now = performance.now(), hz = Math.max(1, +S.cfg.hands_hz || 60);
    S.handsBudget = Math.min(1, S.handsBudget + (now - S.handsT) * hz / 1000);
    S.handsT = now;
    if (S.handsBudget < 1 && !force) return null;
    const msg = { type: 'hands', seq: ++S.seq, t: now, left: handMsg(S.hands.left), right: handMsg(S.hands.right) };
    if (send(msg)) { S.handsBudget = Math.max(0, S.handsBudget - 1); S.handsSent++; S.handsLast = now; }
    return msg;
  }
  const handBuf = new Float32Array(16 * JOINTS.length);
  function xrHand(frame, hand, ref) {
    const spaces = JOINTS.map((n) => hand.get(n));
    if (spaces.some((sp) => !sp)) return null;
    let j = [];
    if (typeof frame.fillPoses === 'function') {
      if (!frame.fillPoses(spaces, ref, handBuf)) return null; // some joint not tracked now
      j = spaces.map((_, i) => [handBuf[16 * i + 12], handBuf[16 * i + 13], handBuf[16 * i + 14]]);
    } else {
      for (const sp of spaces) { const p = frame.getJointPose(sp, ref); if (!p) return null; j.push(vec(p.transform.position)); }
    }
    const wrist = frame.getJointPose(spaces[0], ref);
    return wrist ? { j, q: quat(wrist.transform.orientation) } : null;
  }
  function xrHands(frame, ref) {
    const out = { left: null, right: null };
    for (const src of frame.session.inputSources) {
      if (src.hand && (src.handedness === 'left' || src.handedness === 'right')) out[src.handedness] = xrHand(frame, src.hand, ref);
    }
    const seen = !!(out.left || out.right);
    if (seen !== S.handsSeen) {
      S.handsSeen = seen;
      $('msg').textContent = seen ? '' : 'no tracked hands: put the controllers down (hand tracking on in the headset)';
    }
    return out;
  }
  function handsMode(on) {
    document.body.classList.toggle('hands', on);
    $('l-clutch').textContent = on ? 'hands' : 'clutch';
    $('l-target').textContent = on ? 'wrist' : 'target';
  }

  // ---- WebXR ---------------------------------------------------------------------------------------
  const vec = (p) => [p.x, p.y, p.z];
  const quat = (o) => [o.x, o.y, o.z, o.w];
  const dist = (a, b) => Math.hypot(a.x - b.x, a.y - b.y, a.z - b.z);

  async function setupXR() {
    if (!navigator.xr) { $('msg').textContent = 'no WebXR here: use Phone motion (or a headset browser)'; return; }
    for (const [mode, id] of [['immersive-vr', 'enter-vr'], ['immersive-ar', 'enter-ar']]) {
      try { if (await navigator.xr.isSessionSupported(mode)) { $(id).disabled = false; $(id).onclick = () => startXR(mode); } }
      catch (e) { /* not supported */ }
    }
  }
  async function startXR(mode) {
    const opts = { optionalFeatures: ['local-floor', 'hand-tracking'] };
    if (mode === 'immersive-ar') { opts.optionalFeatures.push('dom-overlay'); opts.domOverlay = { root: $('panel') }; }
    const session = await navigator.xr.requestSession(mode, opts);
    const gl = $('gl').getContext('webgl', { xrCompatible: true });
    await gl.makeXRCompatible();
    session.updateRenderState({ baseLayer: new XRWebGLLayer(session, gl) });
    let ref;
    try { ref = await session.requestReferenceSpace('local-floor'); } catch (e) { ref = await session.requestReferenceSpace('local'); }
    S.xr = { session, ref, selecting: new Set() };
    session.addEventListener('selectstart', (e) => S.xr && S.xr.selecting.add(e.inputSource));
    session.addEventListener('selectend', (e) => S.xr && S.xr.selecting.delete(e.inputSource));
    session.addEventListener('end', () => {
      S.xr = null; submit({ pose: null, clutch: false, trigger: 0, source: 'buttons' });
      if (S.cfg.hands) { submitHands(null, 'xr-hand', true); S.hands = null; S.handsSeen = null; }
    });
    const onFrame = (t, frame) => {
      session.requestAnimationFrame(onFrame);
      const layer = session.renderState.baseLayer;
      gl.bindFramebuffer(gl.FRAMEBUFFER, layer.framebuffer);
      gl.clearColor(0, 0, 0, mode === 'immersive-ar' ? 0 : 1); gl.clear(gl.COLOR_BUFFER_BIT);
      if (S.cfg.hands) submitHands(xrHands(frame, ref), 'xr-hand');
      const s = xrSample(frame, ref, mode);
      if (s) submit(s);
    };
    session.requestAnimationFrame(onFrame);
  }
  function xrSample(frame, ref, mode) {
    const sources = Array.from(frame.session.inputSources);
    const pick = sources.find((s) => s.handedness === S.cfg.hand && (s.gripSpace || s.hand))
      || sources.find((s) => s.gripSpace || s.hand);
    if (pick && pick.hand) { // hand tracking: wrist pose; middle-finger pinch = clutch, index pinch = gripper
      const j = (n) => frame.getJointPose(pick.hand.get(n), ref);
      const wrist = j('wrist'), thumb = j('thumb-tip'), index = j('index-finger-tip'), middle = j('middle-finger-tip');
      if (!wrist) return null;
      const pinch = (a) => (a && thumb ? dist(a.transform.position, thumb.transform.position) : 1);
      const grip = Math.min(1, Math.max(0, (0.08 - pinch(index)) / 0.06));
      return { pose: { p: vec(wrist.transform.position), q: quat(wrist.transform.orientation) },
        clutch: pinch(middle) < 0.02 || S.clutchBtn, trigger: grip, source: 'xr-hand' };
    }
    if (pick && pick.gripSpace) { // controller: grip (squeeze) = clutch, trigger = gripper, A/X = mode, B/Y = finish
      const pose = frame.getPose(pick.gripSpace, ref);
      if (!pose) return null;
      const b = (pick.gamepad && pick.gamepad.buttons) || [];
      if (b[4] && b[4].pressed) S.mode = true;
      if (b[5] && b[5].pressed) S.done = true;
      const transient = pick.targetRayMode === 'transient-pointer'; // Vision Pro gaze-and-pinch
      return { pose: { p: vec(pose.transform.position), q: quat(pose.transform.orientation) },
        clutch: (b[1] && b[1].pressed) || (transient && S.xr.selecting.has(pick)) || S.clutchBtn,
        trigger: b[0] ? b[0].value : (S.gripBtn ? 1 : 0), source: 'xr-controller' };
    }
    if (mode === 'immersive-ar') { // a phone in AR: the phone itself is the controller
      const v = frame.getViewerPose(ref);
      if (!v) return null;
      return { pose: { p: vec(v.transform.position), q: quat(v.transform.orientation) },
        clutch: S.clutchBtn, trigger: S.gripBtn ? 1 : 0, source: 'xr-viewer' };
    }
    return null;
  }

  // ---- phones without WebXR AR: orientation + on-screen jog buttons --------------------------------
  function orientationQuat(e) { // device -> earth (Z-X'-Y''), then earth (x east, y north, z up) -> XR (y up, -z north)
    const d = Math.PI / 180, a = (e.alpha || 0) * d, b = (e.beta || 0) * d, g = (e.gamma || 0) * d;
    const [ca, sa, cb, sb, cg, sg] = [Math.cos(a), Math.sin(a), Math.cos(b), Math.sin(b), Math.cos(g), Math.sin(g)];
    const R = [[ca * cg - sa * sb * sg, -sa * cb, ca * sg + sa * sb * cg],
               [sa * cg + ca * sb * sg, ca * cb, sa * sg - ca * sb * cg],
               [-cb * sg, sb, cb * cg]];
    const M = [R[0], R[2], R[1].map((x) => -x)]; // rows: xr x = east, xr y = up, xr z = south
    const tr = M[0][0] + M[1][1] + M[2][2];
    let w, x, y, z;
    if (tr > 0) { const s = Math.sqrt(tr + 1) * 2; w = s / 4; x = (M[2][1] - M[1][2]) / s; y = (M[0][2] - M[2][0]) / s; z = (M[1][0] - M[0][1]) / s; }
    else if (M[0][0] > M[1][1] && M[0][0] > M[2][2]) { const s = Math.sqrt(1 + M[0][0] - M[1][1] - M[2][2]) * 2; w = (M[2][1] - M[1][2]) / s; x = s / 4; y = (M[0][1] + M[1][0]) / s; z = (M[0][2] + M[2][0]) / s; }
    else if (M[1][1] > M[2][2]) { const s = Math.sqrt(1 + M[1][1] - M[0][0] - M[2][2]) * 2; w = (M[0][2] - M[2][0]) / s; x = (M[0][1] + M[1][0]) / s; y = s / 4; z = (M[1][2] + M[2][1]) / s; }
    else { const s = Math.sqrt(1 + M[2][2] - M[0][0] - M[1][1]) * 2; w = (M[1][0] - M[0][1]) / s; x = (M[0][2] + M[2][0]) / s; y = (M[1][2] + M[2][1]) / s; z = s / 4; }
    return [x, y, z, w];
  }
  let lastJog = performance.now();
  function phoneSample(prev) {
    const now = performance.now(), dt = Math.min((now - lastJog) / 1000, 0.1);
    lastJog = now;
    for (let i = 0; i < 3; i++) S.virt[i] += 0.1 * S.jog[i] * dt; // jog buttons move a virtual controller at 0.1 m/s
    const jogging = S.jog.some((v) => v !== 0);
    return { pose: { p: S.virt.slice(), q: S.orient || (prev.pose && prev.pose.q) || [0, 0, 0, 1] },
      clutch: S.clutchBtn || jogging, trigger: S.gripBtn ? 1 : 0, source: S.orient ? 'orientation' : 'buttons' };
  }
  async function startPhone() {
    if (typeof DeviceOrientationEvent !== 'undefined' && typeof DeviceOrientationEvent.requestPermission === 'function') {
      try { await DeviceOrientationEvent.requestPermission(); } catch (e) { /* iOS: refused; buttons still work */ }
    }
    window.addEventListener('deviceorientation', (e) => {
      if (e.alpha === null && e.beta === null) return;
      S.orient = orientationQuat(e);
      submit(phoneSample(S.sample || {}));
    });
    $('jog').style.display = 'grid';
    S.phone = true;
    $('phone').classList.add('on');
  }

  // ---- on-screen buttons -----------------------------------------------------------------------------
  function hold(el, on) {
    const down = (e) => { e.preventDefault(); on(true); el.classList.add('on'); };
    const up = (e) => { e.preventDefault(); on(false); el.classList.remove('on'); };
    el.addEventListener('pointerdown', down);
    for (const ev of ['pointerup', 'pointercancel', 'pointerleave']) el.addEventListener(ev, up);
  }
  hold($('clutch'), (v) => { S.clutchBtn = v; });
  hold($('grip'), (v) => { S.gripBtn = v; });
  document.querySelectorAll('[data-jog]').forEach((el) => {
    const d = el.dataset.jog.split(',').map(Number);
    hold(el, (v) => { S.jog = v ? d : [0, 0, 0]; });
  });
  $('mode').onclick = () => { S.mode = true; };
  $('done').onclick = () => { S.done = true; };
  $('phone').onclick = startPhone;

  // ---- status panel ------------------------------------------------------------------------------------
  function link(text, ok) { const el = $('s-link'); el.textContent = text; el.className = ok ? 'good' : 'bad'; }
  function showStatus(m) {
    $('s-rtt').textContent = S.rtt === null ? '-' : `${S.rtt.toFixed(1)} ms`;
    $('s-input').textContent = `${S.source}, ${S.sent} sent` + (S.handsSent ? `, ${S.handsSent} hands` : '')
      + (m.stale ? ' (stale: robot holding)' : '');
    if (m.hands) {
      const tr = (side) => `${side} ${m.hands[side] ? 'tracked' : '-'}`;
      $('s-clutch').textContent = `${tr('left')}, ${tr('right')}`;
    } else {
      $('s-clutch').textContent = m.engaged ? 'following' : (m.need_release ? 'release and press again' : 'released');
    }
    $('s-clutch').className = m.engaged ? 'good' : '';
    $('s-target').textContent = m.target_mm.map((v) => v.toFixed(0)).join(', ') + ' mm';
    $('s-gripper').textContent = m.gripper.toFixed(2);
    $('s-robot').textContent = m.robot ? Object.entries(m.robot).map(([k, v]) => `${k} ${v}`).join('  ') : '-';
    $('s-rejected').textContent = `${m.rejected}`;
  }

  // ---- test and benchmark hooks: the same path as WebXR frames -------------------------------------
  window.__rioInjectPose = (p, q, opts = {}) => submit({ pose: p ? { p, q: q || [0, 0, 0, 1] } : null,
    clutch: !!opts.clutch, trigger: opts.trigger || 0, source: 'test' });
  // hands: left / right each null or {j: 25 x [x, y, z] (XRHand order), q: [x, y, z, w]} (reference space)
  window.__rioInjectHands = (left = null, right = null) => submitHands({ left, right }, 'test');
  window.__rioXRHands = (frame, ref) => xrHands(frame, ref); // what an XR frame's hands read as (no send)
  window.__rioPing = ping;
  window.__rioState = () => ({ connected: !!(S.ws && S.ws.readyState === WebSocket.OPEN), rtt: S.rtt, status: S.status,
    sent: S.sent, handsSent: S.handsSent, config: S.cfg });
  window.__rioButton = (name) => { if (name === 'mode') S.mode = true; if (name === 'done') S.done = true; };

  connect();
  setupXR();
})();
