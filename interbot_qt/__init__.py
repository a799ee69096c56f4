"""Qt-side helpers shared by the Tablet and the Base Station (widgets, socket framing).

`interbot_core` stays Qt-free (STYLE.md, napari's rule); what both Qt applications need lives
here: `interbot_qt.qt_joystick.QtJoystick` (thesis §5.2.2.3) and
`interbot_qt.qt_tcp_connection.QtTcpConnection` (JSON frames over a `QTcpSocket`, §5.3.1) and
`interbot_qt.layout` (the buttons, rows and columns every panel builds).
"""
