# The upper half of the 192-cell subgrid at N = 17 (configs/maps/default_subgrid.toml): f
# 8.06-11.6 Hz, 8 x 12 = 96 cells over 14 s with a 2 s transient (96 stroboscopic samples at
# 8 Hz), as map arguments in HALF17. Sourced by gpu_lease.sh and adaptive_maps_gpu.sh.
HALF17=(configs/maps/default_subgrid.toml --set beam.segments=17
    --set 'map.axes=[{key="excitation.frequency_hz",values=[8.063492063492063,8.571428571428571,9.079365079365079,9.587301587301587,10.095238095238095,10.603174603174603,11.11111111111111,11.619047619047619]},{key="excitation.amplitude_m",values=[0.004,0.0057872340425531915,0.007574468085106383,0.009361702127659575,0.011148936170212766,0.012936170212765958,0.01472340425531915,0.01651063829787234,0.018297872340425535,0.020085106382978724,0.021872340425531916,0.023659574468085108]}]'
    --set integration.duration_s=14.0 --set integration.transient_s=2.0)
