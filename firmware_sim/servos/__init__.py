"""Servo emulators: the Futaba S3003 and the controllers a node reaches it through.

=================  ==========================================================================
``s3003``          the S3003 model: pulse to angle, speed, dead band, power (virtual time)
``bank``           servos fed by pulse ramps, stepped together
``ssc32``          the Lynxmotion SSC-32 ASCII protocol over 32 emulated channels
``ports``          byte ports an emulator serves: a pyserial URL or a new pty
``ssc32_server``   the SSC-32 serving a port in a thread, with mute and cable-cut faults
``servo_can.dbc``  the CAN servo messages (commands, feedback, status, configuration)
``can_servo``      CAN servo nodes on a python-can bus, messages coded with cantools
``cli``            ``python -m firmware_sim.servos``: run an emulator for a terminal or a host
=================  ==========================================================================
"""
