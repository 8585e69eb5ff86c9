-- Raking (thesis §4.1.6, Figs. 4.9, 4.10): a rake with tines is pulled through a box of sand in
-- the style of a Japanese rock garden and leaves parallel grooves that keep their shape.
-- Geometry (not given in the thesis; chosen for its 220x55x220 grid at dx = 4.5 mm): a 0.9 x 0.9 m
-- box of sand 5.4 cm deep in a sticky container; a rake of 7 tines (radius 5 mm, 4 cm apart, 1.5 cm
-- into the sand) under a bar, pulled across in two passes (keyframes: down, across, up, over,
-- down, back). Sand: rho 2200, E 3.537e5, nu 0.3, hardening 35/9/0.2/10. Rake: slip, friction 0.2.
-- Preview quality uses a 0.5 m box, 3 cm deep.
local q = params.quality
local dx = ({paper = 0.0045, preview = 0.012, test = 0.025})[q]
local L = (q == "paper") and 0.9 or 0.5
local depth = (q == "paper") and 0.054 or 0.03
local floor = 0.03
local surface = floor + depth
local tines = {}
for i = -3, 3 do
  tines[#tines + 1] = { type = "cylinder", center = {0, 0, 0.04 * i}, radius = 0.005, half_height = 0.04 }
end
tines[#tines + 1] = { type = "box", center = {0, 0.05, 0}, half_extent = {0.01, 0.01, 0.14} }
local yin = surface - 0.015 + 0.04         -- rake origin when the tines are 1.5 cm deep
local yup = yin + 0.08
local x0, x1 = -L / 2 + 0.06, L / 2 - 0.06
local z0, z1 = -L / 4, L / 4
return {
  dim = 3, dx = dx, ppc = (q == "paper") and 8 or 4,
  fps = 24, frames = (q == "test") and 2 or 168,
  max_dt = 2.5e-4,
  domain = { min = {-L / 2 - 0.03, 0, -L / 2 - 0.03}, max = {L / 2 + 0.03, surface + 0.2, L / 2 + 0.03} },
  materials = {
    sand = { model = "sand", density = 2200, E = 3.537e5, nu = 0.3, hardening = {35, 9, 0.2, 10} },
  },
  objects = {
    { shape = { type = "box", center = {0, floor + depth / 2, 0}, half_extent = {L / 2, depth / 2, L / 2} }, material = "sand" },
  },
  colliders = {
    { shape = { type = "box", center = {0, floor + 0.5, 0}, half_extent = {L / 2, 0.5, L / 2}, inside_out = true },
      mode = "sticky" },
    { shapes = tines, mode = "slip", friction = 0.2,
      keyframes = {
        { t = 0.0, position = {x0, yup, z0} },
        { t = 0.4, position = {x0, yin, z0} },
        { t = 3.0, position = {x1, yin, z0} },
        { t = 3.4, position = {x1, yup, z0} },
        { t = 3.8, position = {x1, yup, z1} },
        { t = 4.2, position = {x1, yin, z1} },
        { t = 6.8, position = {x0, yin, z1} },
        { t = 7.0, position = {x0, yup, z1} },
      } },
  },
  camera = { eye = {0, 0.9 * L + 0.3, 0.35 * L}, target = {0, floor, 0}, up = {0, 1, 0}, fov = 50 },
}
