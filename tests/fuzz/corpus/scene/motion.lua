-- Fixture for tests/test_scene.c: two moving colliders, one by keyframes and one by a Lua motion
-- function, and (with --set fail_after=T) a motion function that raises an error after time T.
local fail_after = params.fail_after or 1e9
local function pose(t)
  if t > fail_after then error("boom at t = " .. t) end
  return {0.3 + 0.1 * t, 0.3 + 0.2 * t * t, 0.2}, axis_angle(0, 0, 1, 30 * t)
end
return {
  dim = 3, dx = 0.025, frames = 6, fps = 24,
  domain = { min = {0, 0, 0}, max = {0.6, 0.6, 0.4} },
  materials = { sand = { friction_angle = 30 } },
  objects = { { shape = { type = "box", center = {0.3, 0.1, 0.2}, half_extent = {0.1, 0.04, 0.1} } } },
  colliders = {
    { shape = { type = "box", center = {0, 0, 0}, half_extent = {0.02, 0.02, 0.02} }, mode = "slip",
      keyframes = {
        { t = 0.0, position = {0.1, 0.4, 0.2} },
        { t = 0.2, position = {0.2, 0.4, 0.2}, axis_angle = {0, 1, 0, 90} },
        { t = 0.3, position = {0.2, 0.5, 0.2}, rotation = {1, 0, 0, 0} },
      } },
    { shape = { type = "sphere", center = {0, 0, 0}, radius = 0.03 }, mode = "separate", motion = pose },
  },
}
