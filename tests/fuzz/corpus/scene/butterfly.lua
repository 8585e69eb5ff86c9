-- Drawing in sand (thesis §4.1.6, Figs. 4.7, 4.8): a stylus is drawn through a box of sand along
-- a butterfly curve and leaves a groove that keeps its shape.
-- Geometry (not given in the thesis; chosen for its 220x55x220 grid at dx = 4.5 mm, about 3.8
-- million particles at 8 per cell): a 0.9 x 0.9 m box of sand 5.4 cm deep inside a sticky
-- container; a stylus (capped cylinder, radius 8 mm) reaching 2 cm into the sand, following Fay's
-- butterfly curve r = e^sin(t) - 2 cos(4t) + sin^5((2t - pi)/24) scaled to about 0.6 m across, in
-- 4 s, then lifted. Sand: rho 2200, E 3.537e5, nu 0.3, hardening 35/9/0.2/10. Stylus: slip,
-- friction 0.2. The motion is a Lua function of time, evaluated once per step.
-- Preview quality uses a smaller box (0.5 m, 3 cm deep) and a curve scaled to it.
local q = params.quality
local dx = ({paper = 0.0045, preview = 0.01, test = 0.025})[q]
local L = (q == "paper") and 0.9 or 0.5
local depth = (q == "paper") and 0.054 or 0.03
local floor = 0.03
local surface = floor + depth
local scale = (q == "paper") and 0.055 or 0.03
local T = 4.0
local function stylus(t)
  local y = surface - 0.02 + 0.06          -- centre of the stylus: tip 2 cm below the surface
  if t < 0.25 then y = y + 0.08 * (1 - t / 0.25) end
  if t > T + 0.25 then y = y + math.min(0.08, 0.08 * (t - T - 0.25) / 0.25) end
  local th = 2 * math.pi * math.min(math.max(t - 0.25, 0), T) / T
  local r = math.exp(math.sin(th)) - 2 * math.cos(4 * th) + math.sin((2 * th - math.pi) / 24) ^ 5
  return { scale * math.sin(th) * r, y, -scale * math.cos(th) * r + 0.25 * scale }
end
return {
  dim = 3, dx = dx, ppc = (q == "paper") and 8 or 4,
  fps = 24, frames = (q == "test") and 2 or 108,
  max_dt = 2.5e-4,
  domain = { min = {-L / 2 - 0.03, 0, -L / 2 - 0.03}, max = {L / 2 + 0.03, surface + 0.16, L / 2 + 0.03} },
  materials = {
    sand = { model = "sand", density = 2200, E = 3.537e5, nu = 0.3, hardening = {35, 9, 0.2, 10} },
  },
  objects = {
    { shape = { type = "box", center = {0, floor + depth / 2, 0}, half_extent = {L / 2, depth / 2, L / 2} }, material = "sand" },
  },
  colliders = {
    { shape = { type = "box", center = {0, floor + 0.5, 0}, half_extent = {L / 2, 0.5, L / 2}, inside_out = true },
      mode = "sticky" },
    { shape = { type = "cylinder", center = {0, 0, 0}, radius = 0.008, half_height = 0.06 },
      mode = "slip", friction = 0.2, motion = function(t) return stylus(t) end },
  },
  camera = { eye = {0, 0.9 * L + 0.3, 0.35 * L}, target = {0, floor, 0}, up = {0, 1, 0}, fov = 50 },
}
