"""The operator's picture in a browser: ``mavhelm run --web [HOST:]PORT``.

``picture`` turns the helm's tasks and the bus into plain data (the map's shapes, the vehicle,
the helm's state); ``view`` is the community app that builds a frame a few times a second and
hands it over without waiting; ``server`` serves the page and pushes the frames over a
websocket from its own thread; ``control`` turns the page's buttons into the MAVLink commands a
ground station would send the companion.
"""
