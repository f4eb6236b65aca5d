"""Servo emulators: the Futaba S3003 and the controllers a node reaches it through.

====================  ==========================================================================
``errors``            the exception tree under ServoEmulatorError (a FirmwareSimError)
``datasheet``         the S3003's and the SSC-32's published figures, data only: what the
                      emulators and the HexManipulator's servo bus clients both read
``s3003``             the S3003 model: a shaft following its pulse, power (virtual time)
``bank``              servos fed by pulse ramps, stepped together
``ssc32``             the Lynxmotion SSC-32 ASCII protocol over 32 emulated channels
``ports``             byte ports an emulator serves: a pyserial URL or a new pty
``serving``           the thread an emulator server runs: steps until stopped or the link fails
``ssc32_server``      the SSC-32 serving a port in a thread, with mute and cable-cut faults
``servo_can.dbc``     the CAN servo messages (commands, feedback, status, configuration)
``can_servo``         CAN servo nodes' logic, messages coded with cantools
``can_servo_server``  the CAN servo nodes serving a python-can bus in a thread
``bus_off``           a python-can bus wrapper that can go bus-off, for fault injection
``cli``               ``python -m firmware_sim.servos``: run an emulator for a terminal or a host
====================  ==========================================================================
"""
