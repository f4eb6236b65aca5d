"""Servo emulators: the Futaba S3003 and the controllers a node reaches it through.

A program of its own beside the emulated nodes (it imports no part of `firmware_sim`):

====================  =========================================================================
``errors``            the exception tree under ServoEmulatorError
``datasheet``         the S3003's and the SSC-32's published figures, data only: what the
                      emulators and the HexManipulator's servo bus clients both read
``s3003``             the S3003 model: a shaft following its pulse, power (virtual time)
``bank``              servos fed by pulse ramps, stepped together
``ssc32``             the Lynxmotion SSC-32 ASCII protocol over 32 emulated channels
``byte_ports``        byte ports an emulator serves: a pyserial URL or a new pty
``serving``           the thread an emulator server runs: steps until stopped or the link fails
``ssc32_server``      the SSC-32 serving a port in a thread, with mute and cable-cut faults
``servo_can.dbc``     the CAN servo messages (commands, feedback, status, configuration)
``can_servo``         CAN servo nodes' logic, messages coded with cantools
``can_servo_server``  the CAN servo nodes serving a python-can bus in a thread
``lock_step``         the CAN servo nodes' virtual clock, moved by the time stamped on frames
``bus_off``           a python-can bus wrapper that can go bus-off, for fault injection
``cli``               ``python -m servo_emulators``: run an emulator for a terminal or a host
====================  =========================================================================
"""
