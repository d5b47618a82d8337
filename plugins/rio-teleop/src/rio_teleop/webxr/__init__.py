"""teleop.webxr: VR/AR headsets and phones in the browser (WebXR), over HTTPS and a WebSocket.

`node.WebXRTeleop` is the driver (`node.WebXRHands`, `teleop.webxr_hands`: the same page streaming
both tracked hands, a hand tracker); `server` the HTTPS/WebSocket server; `protocol` what the page
may send; `mapping` the clutch and the pose -> twist mapping, and the hands -> hand tracker contract;
`certs` the self-signed certificate; `static/` the page (plain JavaScript, no build step);
`bench.webxr_latency` the latency figures.
"""
