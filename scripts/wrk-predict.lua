-- wrk load script for POST /api/predict (BENCHMARKS.md, issue 8).
--
-- Each request asks for another template profile, as a user dragging the
-- GUI's sliders would: the surface cycles bump, edge, sine and the width
-- r_w steps through 0.14 .. 3.0 mm in the slider's 0.02 mm steps (so some
-- requests fall beyond the database's 0.5 .. 2.5 mm and are answered as
-- extrapolations), height 0.27 mm, 20 mm/s, x0 = 5 mm. Every answer is the
-- JSON profile with its surface height (501 points, about 21 KB).
--
-- With `haptex serve` listening, from the repository root:
--   wrk -t2 -c32 -d30s --latency -s scripts/wrk-predict.lua http://127.0.0.1:8080/api/predict

local surfaces = { "bump", "edge", "sine" }
local counter = 0

wrk.method = "POST"
wrk.headers["Content-Type"] = "application/json"

function request()
  counter = counter + 1
  local surface = surfaces[counter % 3 + 1]
  local width = 0.14 + 0.02 * (counter % 144)
  local body = string.format(
    '{"surface": "%s", "x0_mm": 5, "width_mm": %.2f, "height_mm": 0.27, "velocity_mm_s": 20}', surface, width)
  return wrk.format(nil, nil, nil, body)
end

dofile("scripts/wrk-report.lua")
