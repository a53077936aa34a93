"""Line-of-sight guidance for vehicles with a propeller and a rudder: law, autopilots, simulation."""
