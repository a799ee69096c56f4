<?xml version="1.0" encoding="utf-8"?>
<!DOCTYPE TS>
<TS version="2.1" language="pt_PT">
<context>
    <name>QtHelpConfirmDialog</name>
    <message>
        <location filename="../../tablet_app/qt_dialogs.py" line="284"/>
        <source>Help me!</source>
        <translation>Ajuda-me!</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_dialogs.py" line="286"/>
        <source>Am I at %1, facing its door?</source>
        <translation>Estou em %1, virado para a porta?</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_dialogs.py" line="288"/>
        <source>Yes, you are here</source>
        <translation>Sim, estás aqui</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_dialogs.py" line="289"/>
        <source>No</source>
        <translation>Não</translation>
    </message>
</context>
<context>
    <name>QtJoystickScreen</name>
    <message>
        <location filename="../../tablet_app/qt_joystick_screen.py" line="133"/>
        <source>Path clear</source>
        <translation>Caminho livre</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_joystick_screen.py" line="133"/>
        <source>Obstacle near: slowing down</source>
        <translation>Obstáculo perto: a abrandar</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_joystick_screen.py" line="133"/>
        <source>Speed limited</source>
        <translation>Velocidade limitada</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_joystick_screen.py" line="133"/>
        <source>Obstacle ahead: slowing down</source>
        <translation>Obstáculo à frente: a abrandar</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_joystick_screen.py" line="133"/>
        <source>Stopped: obstacle too close</source>
        <translation>Parado: obstáculo demasiado perto</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_joystick_screen.py" line="133"/>
        <source>Stopped: the robot cannot see</source>
        <translation>Parado: o robô não consegue ver</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_joystick_screen.py" line="133"/>
        <source>Driving assistance on</source>
        <translation>Assistência à condução ligada</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_joystick_screen.py" line="129"/>
        <source>Latency: –</source>
        <translation>Latência: –</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_joystick_screen.py" line="132"/>
        <source>Latency: %1 ms</source>
        <translation>Latência: %1 ms</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_joystick_screen.py" line="141"/>
        <source>Connection is lossy: commands will not be obeyed until it recovers.</source>
        <translation>Ligação com perdas: os comandos não serão obedecidos até que recupere.</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_joystick_screen.py" line="143"/>
        <source>Maximum linear speed</source>
        <translation>Velocidade linear máxima</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_joystick_screen.py" line="144"/>
        <source>Maximum angular speed</source>
        <translation>Velocidade angular máxima</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_joystick_screen.py" line="145"/>
        <source>Back</source>
        <translation>Voltar</translation>
    </message>
</context>
<context>
    <name>QtMainMenu</name>
    <message>
        <location filename="../../tablet_app/qt_main_menu.py" line="72"/>
        <source>Average latency: –</source>
        <translation>Latência média: –</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_main_menu.py" line="75"/>
        <source>Average latency: %1 ms</source>
        <translation>Latência média: %1 ms</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_main_menu.py" line="79"/>
        <source>Interbot</source>
        <translation>Interbot</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_main_menu.py" line="80"/>
        <source>Joystick</source>
        <translation>Joystick</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_main_menu.py" line="81"/>
        <source>Map</source>
        <translation>Mapa</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_main_menu.py" line="82"/>
        <source>Home</source>
        <translation>Casa</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_main_menu.py" line="83"/>
        <source>Report a malfunction</source>
        <translation>Reportar uma avaria</translation>
    </message>
</context>
<context>
    <name>QtMalfunctionDialog</name>
    <message>
        <location filename="../../tablet_app/qt_dialogs.py" line="333"/>
        <source>Report a malfunction</source>
        <translation>Reportar uma avaria</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_dialogs.py" line="334"/>
        <source>What went wrong?</source>
        <translation>O que correu mal?</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_dialogs.py" line="335"/>
        <source>Collision</source>
        <translation>Colisão</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_dialogs.py" line="336"/>
        <source>Wrong position</source>
        <translation>Posição errada</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_dialogs.py" line="337"/>
        <source>Wrong orientation</source>
        <translation>Orientação errada</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_dialogs.py" line="338"/>
        <source>Other</source>
        <translation>Outro</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_dialogs.py" line="339"/>
        <source>Details (optional)</source>
        <translation>Detalhes (opcional)</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_dialogs.py" line="340"/>
        <source>Send</source>
        <translation>Enviar</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_dialogs.py" line="341"/>
        <source>Cancel</source>
        <translation>Cancelar</translation>
    </message>
</context>
<context>
    <name>QtMapScreen</name>
    <message>
        <location filename="../../tablet_app/qt_map_screen.py" line="75"/>
        <source>Drive me with the joystick to one of the highlighted rooms, then tap that room on the map.</source>
        <translation>Conduz-me com o joystick até uma das salas destacadas e depois toca nessa sala no mapa.</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_map_screen.py" line="80"/>
        <source>I do not know where I am.</source>
        <translation>Não sei onde estou.</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_map_screen.py" line="83"/>
        <source>Help me!</source>
        <translation>Ajuda-me!</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_map_screen.py" line="84"/>
        <source>Joystick</source>
        <translation>Joystick</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_map_screen.py" line="85"/>
        <source>Guided tour</source>
        <translation>Visita guiada</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_map_screen.py" line="86"/>
        <source>Home</source>
        <translation>Casa</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_map_screen.py" line="87"/>
        <source>Menu</source>
        <translation>Menu</translation>
    </message>
</context>
<context>
    <name>QtMotionBar</name>
    <message>
        <location filename="../../tablet_app/qt_motion_bar.py" line="60"/>
        <source>Going to %1</source>
        <translation>A caminho de %1</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_motion_bar.py" line="63"/>
        <source>Pause</source>
        <translation>Pausa</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_motion_bar.py" line="64"/>
        <source>Resume</source>
        <translation>Retomar</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_motion_bar.py" line="65"/>
        <source>Cancel</source>
        <translation>Cancelar</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_motion_bar.py" line="66"/>
        <source>Manual control</source>
        <translation>Controlo manual</translation>
    </message>
</context>
<context>
    <name>QtRequestDialog</name>
    <message>
        <location filename="../../tablet_app/qt_dialogs.py" line="146"/>
        <source>Request</source>
        <translation>Pedido</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_dialogs.py" line="147"/>
        <source>What should I ask for in %1?</source>
        <translation>O que devo pedir em %1?</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_dialogs.py" line="148"/>
        <source>Type your request</source>
        <translation>Escreve o teu pedido</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_dialogs.py" line="149"/>
        <source>Deliver to:</source>
        <translation>Entregar a:</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_dialogs.py" line="150"/>
        <source>Send</source>
        <translation>Enviar</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_dialogs.py" line="151"/>
        <source>Cancel</source>
        <translation>Cancelar</translation>
    </message>
</context>
<context>
    <name>QtRoomDialog</name>
    <message>
        <location filename="../../tablet_app/qt_dialogs.py" line="98"/>
        <source>Take me there</source>
        <translation>Leva-me lá</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_dialogs.py" line="99"/>
        <source>Request / deliver</source>
        <translation>Pedir / entregar</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_dialogs.py" line="100"/>
        <source>Close</source>
        <translation>Fechar</translation>
    </message>
</context>
<context>
    <name>QtShowRequestDialog</name>
    <message>
        <location filename="../../tablet_app/qt_dialogs.py" line="242"/>
        <source>Request</source>
        <translation>Pedido</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_dialogs.py" line="244"/>
        <source>A request for %1, to be delivered to %2:</source>
        <translation>Um pedido para %1, a entregar em %2:</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_dialogs.py" line="248"/>
        <source>Accept</source>
        <translation>Aceitar</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_dialogs.py" line="249"/>
        <source>Decline</source>
        <translation>Recusar</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_dialogs.py" line="250"/>
        <source>Close</source>
        <translation>Fechar</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_dialogs.py" line="253"/>
        <source>Thank you! I am taking it to %1.</source>
        <translation>Obrigado! Vou levá-lo para %1.</translation>
    </message>
</context>
<context>
    <name>QtTourStopDialog</name>
    <message>
        <location filename="../../tablet_app/qt_dialogs.py" line="188"/>
        <source>Guided tour</source>
        <translation>Visita guiada</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_dialogs.py" line="189"/>
        <source>Resume tour</source>
        <translation>Continuar a visita</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_dialogs.py" line="190"/>
        <source>End tour</source>
        <translation>Terminar a visita</translation>
    </message>
</context>
<context>
    <name>TabletWindow</name>
    <message>
        <location filename="../../tablet_app/main_window.py" line="221"/>
        <source>Not connected: the command was not sent.</source>
        <translation>Sem ligação: o comando não foi enviado.</translation>
    </message>
    <message>
        <location filename="../../tablet_app/main_window.py" line="276"/>
        <source>Thank you! I am at %1.</source>
        <translation>Obrigado! Estou em %1.</translation>
    </message>
    <message>
        <location filename="../../tablet_app/main_window.py" line="358"/>
        <source>Arrived at %1.</source>
        <translation>Cheguei a %1.</translation>
    </message>
    <message>
        <location filename="../../tablet_app/main_window.py" line="374"/>
        <source>Cancelled by the operator: %1</source>
        <translation>Cancelado pelo operador: %1</translation>
    </message>
    <message>
        <location filename="../../tablet_app/main_window.py" line="392"/>
        <source>Base Station: %1</source>
        <translation>Estação Base: %1</translation>
    </message>
    <message>
        <location filename="../../tablet_app/main_window.py" line="395"/>
        <source>Refused by the Base Station: %1</source>
        <translation>Recusado pela Estação Base: %1</translation>
    </message>
    <message>
        <location filename="../../tablet_app/main_window.py" line="414"/>
        <source>Connected to %1</source>
        <translation>Ligado a %1</translation>
    </message>
    <message>
        <location filename="../../tablet_app/main_window.py" line="417"/>
        <source>%1 ms</source>
        <translation>%1 ms</translation>
    </message>
    <message>
        <location filename="../../tablet_app/main_window.py" line="419"/>
        <source>Connecting to %1…</source>
        <translation>A ligar a %1…</translation>
    </message>
    <message>
        <location filename="../../tablet_app/main_window.py" line="421"/>
        <source>Disconnected: reconnecting in %1 s</source>
        <translation>Desligado: a voltar a ligar dentro de %1 s</translation>
    </message>
    <message>
        <location filename="../../tablet_app/main_window.py" line="425"/>
        <source>Disconnected</source>
        <translation>Desligado</translation>
    </message>
    <message>
        <location filename="../../tablet_app/main_window.py" line="457"/>
        <source>Interbot Tablet</source>
        <translation>Tablet do Interbot</translation>
    </message>
</context>
</TS>
