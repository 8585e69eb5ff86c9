local s = string.format("%5.2f %q %s", 1.5, "a\0b", {}) .. utf8.char(0x10FFFF)
for w in string.gmatch("a b c", "%a") do s = s .. w end
s = s:gsub("%s", "_"):upper():sub(-3, 2):rep(3, ",")
table.sort({3, 1, 2}, function(a, b) return a > b end)
return { dim = 2, dx = 0.125, frames = 1, domain = { min = {0, 0}, max = {1, 1} }, materials = { sand = { friction_angle = 33 } },
  objects = { { shape = { type = "halfspace", point = {0, 0.5}, normal = {0, 1} } } }, outputs = { ply = false } }
