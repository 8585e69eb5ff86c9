local ok = pcall(function() local s = string.rep("ab", 1e6) return szfind("(achar*)--(F*b") end)
local t =para