"""An independent generator of recordings with concealed physics, for reporting a
diagnosis benchmark (``python -m benchmarks.independent.generate``).

It shares no code with suspenv's diagnosis engine or its component and rig models: it
imports only :mod:`suspenv.measurements` (the :class:`~suspenv.measurements.Recording`
and :func:`~suspenv.measurements.save_recording` of the file format), numpy and scipy.
Its physics, parameterisations and integration are its own.

Devices (``devices.py``), each with the user's baseline physics plus at most one
concealed effect:

* a gas damper on a dyno driven by faded sines at two amplitudes and three frequencies:
  ``c v + f_gas + k_gas x``;
* an MR damper on a shaking table (sines 5-20 mm, 0.5-3 Hz, constant coil voltage):
  ``c(V) v + k x + f_0``; the Bouc-Wen term of Spencer et al. (1997) and a Bingham yield
  force (Stanway et al. 1987) are effects;
* a carriage on a guide under a PD position loop with feedforward, following minimum-jerk
  moves (Flash and Hogan 1985): ``m a + c v``; velocity and acceleration from a
  Savitzky-Golay differentiator (Savitzky and Golay 1964) of the measured position;
* a 2-DOF quarter car on a shaker (band-limited random or swept road plus bumps,
  optional known actuator force between body and wheel).

Effects (``effects.py``): Coulomb friction smoothed by tanh, the Stribeck curve
(Armstrong-Helouvry, Dupont, Canudas de Wit 1994), LuGre (Canudas de Wit, Olsson, Astrom,
Lischinsky 1995); Bouc-Wen hysteresis (Bouc 1967, Wen 1976); digressive and asymmetric
damping; a Maxwell element; cubic spring; end stop; sensor offset, gain and first-order
lag; and out of library: cubic damping, a velocity dead zone, free play (backlash) and a
pure time delay. Integration (``integrate.py``): scipy's LSODA (Hindmarsh 1983, Petzold
1983) with tight tolerances sampled from its dense output, and exact discretisations of
the linear sensor filters. Noise (``noise.py``): white, AR(1) coloured, or white plus a
slow zero drift. Cases, labels and magnitudes: ``cases.py``; files: ``export.py``.
"""
