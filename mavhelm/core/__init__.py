"""The bottom layer: bus, app, community, clock, mission files and their parameter schema,
located errors, geodesy and the variable names every layer shares. Imports no other part of
mavhelm, so tasks/, nav/, companion/ and the simulator can all stand on it."""
