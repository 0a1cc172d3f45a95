"""Plant connectivity: loops from an OPC UA server or a historian's exports into the Zenoh key space.

``loopfile`` reads the loop file, ``sampler`` turns OPC UA value changes into ``SampleBatch``
messages (pure), ``replay`` schedules exports (pure), ``opcua`` and ``publish`` are the edges.
"""
