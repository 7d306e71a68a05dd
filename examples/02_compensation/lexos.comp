tendyn-transmission-model 1
# units: SI (m, N, N s/m, rad, rad/s, N m); matrices row-major [i, j], indices 0-based
n 4
motor_radius 0.008 0.008 0.008 0.008
K 0.32 0 0 0 0.015 0.32 0 0 0.015 -0.015 0.09 0 0.015 -0.015 0.015 0.24
driven_radius 0.04 0.04 0.09 0.03
reducer_ratio 8 8 1 8
reducer_efficiency 0.9 0.9 1 0.9
pretension 50 50 50 50
tau0 1 0 0 0 1 1 0 0 1 1 1 0 1 1 1 1
nu 10 0 0 0 10 10 0 0 10 10 10 0 10 10 10 10
beta 0.02 0 0 0 0.02 0.02 0 0 0.02 0.02 0.02 0 0.02 0.02 0.02 0.02
bearing_count 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0
bearing_radius 1 1 1 1 1 1 1 1 1 1 1 1 1 1 1 1
bearing_wrap 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0
bearing_static_coefficient 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0
bearing_dynamic_coefficient 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0
bearing_h0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0
bearing_h1 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0
bearing_n0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0
section chain 1
# kinematics and gravity of the driven chain (include/tendyn/chain.hpp), indices 0-based
device L-EXOS
n 4
gravity 0 0 -9.81
parent -1 0 1 2
placement 1 0 0 0 1 0 0 0 1 0 0 0 1 0 0 0 6.123233995736766e-17 1 0 -1 6.123233995736766e-17 0 0 0 6.123233995736766e-17 6.123233995736766e-17 -1 -1 3.749399456654644e-33 -6.123233995736766e-17 0 1 6.123233995736766e-17 0 0 0 1 0 0 0 6.123233995736766e-17 1 0 -1 6.123233995736766e-17 0 0 0.3
axis 0 0 1 0 0 1 0 0 1 0 0 1
prismatic 0 0 0 0
mass 2 2 1.2 0.8
com 0.05 0 0 -0.12 -7.3478807948841184e-18 7.3478807948841184e-18 0 2.4492935982947064e-18 0.26 0.14 0 0
ee_joint 3
ee_point 0.32 0 0
section compensator 1
# settings: k [-], velocity band [rad/s] motor side, filter cut-off [Hz], control rate [Hz]
underestimation 0.9
velocity_band 0.5
velocity_cutoff_hz 30
rate_hz 1000
section losses 1
# source of each loss term: device (the device file), identified (FRICTION.json), none (lossless)
tau0 device
nu device
beta device
bearings device
reducer_efficiency device
