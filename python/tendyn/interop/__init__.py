"""Out to other software: a device as a MuJoCo model (:mod:`tendyn.interop.mjcf`) and its coupling as ros2_control
transmissions (:mod:`tendyn.interop.ros2_control`). Both take the coupling from :func:`tendyn.coupling.coupling`;
reading other software's coupling files is :mod:`tendyn.io.coupling_file` (``tendyn routing import``)."""
