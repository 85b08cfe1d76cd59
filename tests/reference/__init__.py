"""Plain reference implementations that the engine's tests hold it to.

:mod:`tests.reference.dense` is the spiking network of ``docs/model.md`` written densely, frame by
frame, in NumPy, for clarity rather than speed; :mod:`tests.reference.columns` holds many windows
as the columns the engine reads, without the checks of ``uavsnn.windows.Windows``.
"""
