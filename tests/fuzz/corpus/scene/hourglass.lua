-- Hourglass (thesis §4.1.5, Figs. 4.5, 4.6): sand at rest in the upper bulb pours through the neck
-- and piles in the lower bulb. The glass is a collider of revolution: the complement of the union
-- of two spheres and a neck cylinder (a container), so nothing leaks through its wall.
-- Geometry (not given in the thesis; chosen for its 160x360x160 grid at dx = 2.5 mm): bulbs of
-- radius 0.1 m centred 0.3 m apart, a neck of radius 1 cm (at least 3 cells wide at coarse
-- quality), sand filling the bottom 7 cm of the upper bulb (about 0.6 million particles at paper
-- quality). Sand: rho 2200, E 3.537e5, nu 0.3, hardening 35/9/0.3/10. Glass: slip, friction 0.3.
local q = params.quality
local dx = ({paper = 0.0025, preview = 0.006, test = 0.012})[q]
local ppc = (q == "paper") and 8 or 4
local cx, cz = 0.2, 0.2
local rb = 0.1
local top, bottom = 0.6, 0.3
local neck = math.max(0.01, 3 * dx)
return {
  dim = 3, dx = dx, ppc = ppc,
  fps = (q == "test") and 24 or 48, frames = (q == "test") and 2 or ((q == "paper") and 384 or 144),
  max_dt = 1e-4,
  domain = { min = {0, 0.1, 0}, max = {0.4, 0.8, 0.4} },
  materials = {
    sand = { model = "sand", density = 2200, E = 3.537e5, nu = 0.3, hardening = {35, 9, 0.3, 10} },
  },
  objects = {
    { shape = { type = "sphere", center = {cx, top, cz}, radius = rb - 1.5 * dx }, material = "sand",
      clip = { type = "halfspace", point = {0, top - rb + 0.07, 0}, normal = {0, 1, 0} } },
  },
  colliders = {
    { shapes = {
        { type = "sphere", center = {cx, top, cz}, radius = rb },
        { type = "sphere", center = {cx, bottom, cz}, radius = rb },
        { type = "cylinder", center = {cx, (top + bottom) / 2, cz}, radius = neck, half_height = (top - bottom) / 2 },
      },
      inside_out = true, mode = "slip", friction = 0.3 },
  },
  camera = { eye = {0.75, 0.5, 0.75}, target = {0.2, 0.45, 0.2}, up = {0, 1, 0}, fov = 40 },
}
