-- wrk load script for POST /api/voltage (BENCHMARKS.md, issue 8).
--
-- Sends the README's example friction profile (data/examples/bump_friction.csv,
-- 1001 points) with the paper's default device, eq. (8):
--   HAPTEX_WRK_BODY=csv  (default) as a text/csv body: the upload path;
--   HAPTEX_WRK_BODY=json as a JSON body {"profile": {"x_mm": [...], "mu": [...]}}.
--
-- Run from the repository root, with `haptex serve` listening:
--   wrk -t2 -c32 -d30s --latency -s scripts/wrk-voltage.lua http://127.0.0.1:8080/api/voltage

local path = "data/examples/bump_friction.csv"
local file = assert(io.open(path, "rb"), "run wrk from the repository root: " .. path .. " not found")
local csv = file:read("*a")
file:close()

wrk.method = "POST"
if os.getenv("HAPTEX_WRK_BODY") == "json" then
  local xs, mus = {}, {}
  for line in csv:gmatch("[^\n]+") do
    local x, mu = line:match("^%s*([%d%.eE+-]+)%s*,%s*([%d%.eE+-]+)%s*$")
    if x then
      xs[#xs + 1] = x
      mus[#mus + 1] = mu
    end
  end
  wrk.body = '{"profile": {"x_mm": [' .. table.concat(xs, ",") .. '], "mu": [' .. table.concat(mus, ",") .. ']}}'
  wrk.headers["Content-Type"] = "application/json"
else
  wrk.body = csv
  wrk.headers["Content-Type"] = "text/csv"
end

dofile("scripts/wrk-report.lua")
