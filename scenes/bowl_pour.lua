-- Pouring into a mesh container (issue 15): sand runs from a spout into the bowl of
-- scenes/meshes/bowl.obj (outer radius 0.2 m, 3 cm wall, a flat foot), which stands on a sticky
-- floor; the sand heaps in the bowl and, once the heap reaches the rim, spills over it. The file
-- has the rim at z = 0 and the foot at z = -0.21 m: turned by -90 degrees about x the bowl opens
-- upwards with the rim at `position` (the file's origin) and the foot 0.21 m below it, on the floor. Sand: rho 2200, E 3.537e5, nu 0.3,
-- friction angle 32 degrees; bowl: sticky (a rough glaze).
local q = params.quality
local dx = ({paper = 0.004, preview = 0.01, test = 0.025})[q]
return {
  dim = 3, dx = dx, ppc = (q == "paper") and 8 or 4,
  fps = 24, end_time = (q == "test") and 0.08 or 4.0,
  max_dt = 5e-4,
  domain = { min = {-0.3, 0, -0.3}, max = {0.3, 0.6, 0.3} },
  materials = { sand = { model = "sand", density = 2200, E = 3.537e5, nu = 0.3, friction_angle = 32 } },
  emitters = {
    { shape = { type = "cylinder", center = {0.03, 0.5, 0}, radius = 0.025, height = 0.04 }, material = "sand",
      velocity = {0, -1, 0}, rate = 2.5, stop = 3.0 },
  },
  colliders = {
    { shape = { type = "halfspace", point = {0, 0.02, 0}, normal = {0, 1, 0} }, mode = "sticky" },
    { shape = { type = "mesh", file = "meshes/bowl.obj", axis_angle = {1, 0, 0, -90}, position = {0, 0.02 + 0.21, 0} },
      mode = "sticky" },
  },
  camera = { eye = {0.55, 0.55, 0.55}, target = {0, 0.12, 0}, up = {0, 1, 0}, fov = 40 },
}
