-- wrk load script: maximal uploads (BENCHMARKS.md, issue 13).
--
-- Each request posts the issue's maximal CSV upload: a friction profile
-- whose header has 10^5 column names (x_mm, mu and 99 998 three-letter
-- names), then as many rows of 10^5 values as fit in the server's 1 MiB
-- body limit (3 rows; 1 000 000 bytes in all). The server parses all of
-- it and answers the 3-point profile. Run with two connections beside
-- the /api/predict load, as two clients uploading back to back:
--
--   wrk -t1 -c2 -d40s -s scripts/wrk-upload.lua http://127.0.0.1:8080/api/profile
--
-- (from the repository root, with `haptex serve` listening; the answer
-- is 200 for every upload, which the closing line's status count checks).

local digits = "abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789"
local names = { "x_mm", "mu" }
for i = 0, 99997 do
  local a = i % 62 + 1
  local b = math.floor(i / 62) % 62 + 1
  local c = math.floor(i / (62 * 62)) + 1
  names[#names + 1] = digits:sub(a, a) .. digits:sub(b, b) .. digits:sub(c, c)
end
local lines = { table.concat(names, ",") }
local zeros = string.rep(",0", 99998)
local size = #lines[1] + 1
local x = 0
while size + #(x .. ",1.1" .. zeros) + 1 <= 1048576 do
  lines[#lines + 1] = x .. ",1.1" .. zeros
  size = size + #lines[#lines] + 1
  x = x + 1
end

wrk.method = "POST"
wrk.headers["Content-Type"] = "text/csv"
wrk.body = table.concat(lines, "\n") .. "\n"

dofile("scripts/wrk-report.lua")
