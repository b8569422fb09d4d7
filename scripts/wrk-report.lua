-- The closing line of the haptex wrk scripts (scripts/wrk-*.lua load it
-- with dofile, so run wrk from the repository root): p99 latency, requests
-- and every kind of error. wrk itself prints "Non-2xx or 3xx responses: N"
-- when any answer was not 2xx/3xx (a per-response Lua hook would slow wrk
-- down).
function done(summary, latency, requests)
  io.write(string.format("p99 latency %.3f ms; %d requests; errors: connect %d, read %d, write %d, status %d, timeout %d\n",
    latency:percentile(99) / 1000, summary.requests, summary.errors.connect, summary.errors.read,
    summary.errors.write, summary.errors.status, summary.errors.timeout))
end
