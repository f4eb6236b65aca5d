"""The HexManipulator: the paper's Stewart-Gough platform, its kinematics and its E-PBO.

=================  ==========================================================================
``geometry``       the platform's measurements as TOML configuration (defaults: hexman.toml)
``kinematics``     pose to crank angles (closed form) and back (Newton), workspace and limits
``servo_bus``      what the HexMan PBO needs from a servo controller: the contract and errors
``ssc32_bus``      that contract over an SSC-32 on a serial port
``can_bus``        that contract over CAN servo nodes (messages from servo_can.dbc)
``hexman_pbo``     the HexMan E-PBO: target pose or yaw in, servo commands out, evaluator
``plot_sweep``     ``python -m hexmanipulator.plot_sweep OUT.png``: the yaw sweep figure
=================  ==========================================================================
"""
