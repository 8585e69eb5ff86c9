local ok = pcall(function() local s = string.rep("ab", 1e6) return s:find("(a*)*b") end)
local t = setmetatable({}, { __index = function(t, k) return k end })
xpcall(function() error(t.x) end, function(m) return m end)
return { dim = 3, dx = 0.5, domain = { min = {0, 0, 0}, max = {1, 1, 1} }, materials = {}, objects = {} }
