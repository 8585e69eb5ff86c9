-- Raking with a mesh tool (issue 15): the rake of scenes/meshes/rake.obj (a 0.5 m bar with ten
-- 8 mm tines 5 cm apart, 8 cm long, pointing down, and a 1 m handle along +z) is pulled through
-- a box of sand toward its handle in two passes, as in scenes/raking.lua, leaving ten grooves
-- per pass. The file's origin is the bar's centre; the tine tips are 9.5 cm below it and go 1.5 cm
-- into the sand. Sand: rho 2200, E 3.537e5, nu 0.3, hardening 35/9/0.2/10. Rake: slip,
-- friction 0.2, in a sticky container.
local q = params.quality
local dx = ({paper = 0.0045, preview = 0.012, test = 0.025})[q]
local L = (q == "paper") and 0.9 or 0.6
local depth = (q == "paper") and 0.054 or 0.03
local floor = 0.03
local surface = floor + depth
local yin = surface - 0.015 + 0.095       -- bar height when the tines are 1.5 cm deep
local yup = yin + 0.06
local z0, z1 = L / 2 - 0.06, -L / 2 + 0.12
local x0, x1 = -L / 4 + 0.02, L / 4 - 0.02
return {
  dim = 3, dx = dx, ppc = (q == "paper") and 8 or 4,
  fps = 24, frames = (q == "test") and 2 or 168,
  max_dt = 2.5e-4,
  domain = { min = {-L / 2 - 0.03, 0, -L / 2 - 0.03}, max = {L / 2 + 0.03, surface + 0.25, L / 2 + 0.03} },
  materials = {
    sand = { model = "sand", density = 2200, E = 3.537e5, nu = 0.3, hardening = {35, 9, 0.2, 10} },
  },
  objects = {
    { shape = { type = "box", center = {0, floor + depth / 2, 0}, half_extent = {L / 2, depth / 2, L / 2} }, material = "sand" },
  },
  colliders = {
    { shape = { type = "box", center = {0, floor + 0.5, 0}, half_extent = {L / 2, 0.5, L / 2}, inside_out = true },
      mode = "sticky" },
    { shape = { type = "mesh", file = "meshes/rake.obj" }, mode = "slip", friction = 0.2,
      keyframes = {
        { t = 0.0, position = {x0, yup, z0} },
        { t = 0.4, position = {x0, yin, z0} },
        { t = 3.0, position = {x0, yin, z1} },
        { t = 3.4, position = {x0, yup, z1} },
        { t = 3.8, position = {x1, yup, z0} },
        { t = 4.2, position = {x1, yin, z0} },
        { t = 6.8, position = {x1, yin, z1} },
        { t = 7.0, position = {x1, yup, z1} },
      } },
  },
  camera = { eye = {0.35 * L, 0.9 * L + 0.3, -0.2 * L}, target = {0, floor, 0}, up = {0, 1, 0}, fov = 50 },
}
