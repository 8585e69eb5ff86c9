return { dim = 2, dx = 0.05, frames = 2, fps = 24, domain = { min = {0, 0}, max = {1, 1} },
  materials = { sand = { friction_angle = 30, density = 1600 }, grit = { E = 1e5, nu = 0.3, friction_angle = 40 } },
  objects = { { material = "grit", shape = { type = "sphere", center = {0.5, 0.5}, radius = 0.1 } } },
  emitters = { { material = "sand", shape = { type = "box", center = {0.5, 0.8}, half_extent = {0.05, 0.05} }, rate = 100,
                 velocity = {0, -1} } } }
