<?xml version="1.0" encoding="utf-8"?>
<!DOCTYPE TS>
<TS version="2.1" language="pt_PT">
<context>
    <name>QtHelpConfirmDialog</name>
    <message>
        <location filename="../../tablet_app/qt_dialogs.py" line="297" />
        <source>Help me!</source>
        <translation>Ajuda-me!</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_dialogs.py" line="299" />
        <source>Am I at %1, facing its door?</source>
        <translation>Estou em %1, virado para a porta?</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_dialogs.py" line="301" />
        <source>Yes, you are here</source>
        <translation>Sim, estás aqui</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_dialogs.py" line="302" />
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
        <location filename="../../tablet_app/qt_joystick_screen.py" line="136" />
        <source>Latency: –</source>
        <translation>Latência: –</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_joystick_screen.py" line="139" />
        <source>Latency: %1 ms</source>
        <translation>Latência: %1 ms</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_joystick_screen.py" line="148" />
        <source>Connection is lossy: commands will not be obeyed until it recovers.</source>
        <translation>Ligação com perdas: os comandos não serão obedecidos até que recupere.</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_joystick_screen.py" line="150" />
        <source>Maximum linear speed</source>
        <translation>Velocidade linear máxima</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_joystick_screen.py" line="151" />
        <source>Maximum angular speed</source>
        <translation>Velocidade angular máxima</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_joystick_screen.py" line="152" />
        <source>Back</source>
        <translation>Voltar</translation>
    </message>
</context>
<context>
    <name>QtKeyboard</name>
    <message>
        <location filename="../../tablet_app/qt_keyboard.py" line="89" />
        <source>Shift</source>
        <translation>Maiúsc.</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_keyboard.py" line="90" />
        <source>Space</source>
        <translation>Espaço</translation>
    </message>
</context>
<context>
    <name>QtMainMenu</name>
    <message>
        <location filename="../../tablet_app/qt_main_menu.py" line="72" />
        <source>Average latency: –</source>
        <translation>Latência média: –</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_main_menu.py" line="75" />
        <source>Average latency: %1 ms</source>
        <translation>Latência média: %1 ms</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_main_menu.py" line="79" />
        <source>Interbot</source>
        <translation>Interbot</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_main_menu.py" line="80" />
        <source>Joystick</source>
        <translation>Joystick</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_main_menu.py" line="81" />
        <source>Map</source>
        <translation>Mapa</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_main_menu.py" line="82" />
        <source>Home</source>
        <translation>Início</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_main_menu.py" line="83" />
        <source>Report a malfunction</source>
        <translation>Reportar uma avaria</translation>
    </message>
</context>
<context>
    <name>QtMalfunctionDialog</name>
    <message>
        <location filename="../../tablet_app/qt_dialogs.py" line="351" />
        <source>Report a malfunction</source>
        <translation>Reportar uma avaria</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_dialogs.py" line="352" />
        <source>What went wrong?</source>
        <translation>O que correu mal?</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_dialogs.py" line="353" />
        <source>Collision</source>
        <translation>Colisão</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_dialogs.py" line="354" />
        <source>Wrong position</source>
        <translation>Posição errada</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_dialogs.py" line="355" />
        <source>Wrong orientation</source>
        <translation>Orientação errada</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_dialogs.py" line="356" />
        <source>Other</source>
        <translation>Outro</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_dialogs.py" line="357" />
        <source>Details (optional)</source>
        <translation>Detalhes (opcional)</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_dialogs.py" line="358" />
        <source>Send</source>
        <translation>Enviar</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_dialogs.py" line="359" />
        <source>Cancel</source>
        <translation>Cancelar</translation>
    </message>
</context>
<context>
    <name>QtMapScreen</name>
    <message>
        <location filename="../../tablet_app/qt_map_screen.py" line="77" />
        <source>Drive me with the joystick to one of the highlighted rooms, then tap that room on the map.</source>
        <translation>Conduz-me com o joystick até uma das salas destacadas e depois toca nessa sala no mapa.</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_map_screen.py" line="82" />
        <source>Checking that I am at %1…</source>
        <translation>A confirmar que estou em %1…</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_map_screen.py" line="84" />
        <source>I do not know where I am.</source>
        <translation>Não sei onde estou.</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_map_screen.py" line="87" />
        <source>Help me!</source>
        <translation>Ajuda-me!</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_map_screen.py" line="88" />
        <source>Joystick</source>
        <translation>Joystick</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_map_screen.py" line="89" />
        <source>Guided tour</source>
        <translation>Visita guiada</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_map_screen.py" line="90" />
        <source>Home</source>
        <translation>Início</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_map_screen.py" line="91" />
        <source>Menu</source>
        <translation>Menu</translation>
    </message>
</context>
<context>
    <name>QtMotionBar</name>
    <message>
        <location filename="../../tablet_app/qt_motion_bar.py" line="60" />
        <source>Going to %1</source>
        <translation>A caminho de %1</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_motion_bar.py" line="63" />
        <source>Pause</source>
        <translation>Pausa</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_motion_bar.py" line="64" />
        <source>Resume</source>
        <translation>Retomar</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_motion_bar.py" line="65" />
        <source>Cancel</source>
        <translation>Cancelar</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_motion_bar.py" line="66" />
        <source>Manual control</source>
        <translation>Controlo manual</translation>
    </message>
</context>
<context>
    <name>QtRequestDialog</name>
    <message>
        <location filename="../../tablet_app/qt_dialogs.py" line="157" />
        <source>Request</source>
        <translation>Pedido</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_dialogs.py" line="159" />
        <source>What should I ask for in %1?</source>
        <translation>O que devo pedir em %1?</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_dialogs.py" line="161" />
        <source>Type your request</source>
        <translation>Escreve o teu pedido</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_dialogs.py" line="162" />
        <source>Deliver to:</source>
        <translation>Entregar a:</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_dialogs.py" line="163" />
        <source>Send</source>
        <translation>Enviar</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_dialogs.py" line="164" />
        <source>Cancel</source>
        <translation>Cancelar</translation>
    </message>
</context>
<context>
    <name>QtRoomDialog</name>
    <message>
        <location filename="../../tablet_app/qt_dialogs.py" line="103" />
        <source>Take me there</source>
        <translation>Leva-me lá</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_dialogs.py" line="104" />
        <source>Request / deliver</source>
        <translation>Pedir / entregar</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_dialogs.py" line="105" />
        <source>Close</source>
        <translation>Fechar</translation>
    </message>
</context>
<context>
    <name>QtShowRequestDialog</name>
    <message>
        <location filename="../../tablet_app/qt_dialogs.py" line="255" />
        <source>Request</source>
        <translation>Pedido</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_dialogs.py" line="257" />
        <source>A request for %1, to be delivered to %2:</source>
        <translation>Um pedido para %1, a entregar em %2:</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_dialogs.py" line="261" />
        <source>Accept</source>
        <translation>Aceitar</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_dialogs.py" line="262" />
        <source>Decline</source>
        <translation>Recusar</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_dialogs.py" line="263" />
        <source>Close</source>
        <translation>Fechar</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_dialogs.py" line="266" />
        <source>Thank you! I am taking it to %1.</source>
        <translation>Obrigado! Vou levá-lo para %1.</translation>
    </message>
</context>
<context>
    <name>QtTourStopDialog</name>
    <message>
        <location filename="../../tablet_app/qt_dialogs.py" line="201" />
        <source>Guided tour</source>
        <translation>Visita guiada</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_dialogs.py" line="202" />
        <source>Resume tour</source>
        <translation>Continuar a visita</translation>
    </message>
    <message>
        <location filename="../../tablet_app/qt_dialogs.py" line="203" />
        <source>End tour</source>
        <translation>Terminar a visita</translation>
    </message>
</context>
<context>
    <name>TabletTexts</name>
    <message>
        <location filename="../../tablet_app/texts.py" line="27" />
        <source>a collision</source>
        <translation>uma colisão</translation>
    </message>
    <message>
        <location filename="../../tablet_app/texts.py" line="28" />
        <source>a wrong position</source>
        <translation>uma posição errada</translation>
    </message>
    <message>
        <location filename="../../tablet_app/texts.py" line="29" />
        <source>a wrong orientation</source>
        <translation>uma orientação errada</translation>
    </message>
    <message>
        <location filename="../../tablet_app/texts.py" line="30" />
        <source>a problem</source>
        <translation>um problema</translation>
    </message>
    <message>
        <location filename="../../tablet_app/texts.py" line="38" />
        <source>Arrived at %1.</source>
        <translation>Cheguei a %1.</translation>
    </message>
    <message>
        <location filename="../../tablet_app/texts.py" line="39" />
        <source>Cancelled. I have stopped.</source>
        <translation>Cancelado. Parei.</translation>
    </message>
    <message>
        <location filename="../../tablet_app/texts.py" line="40" />
        <source>The operator cancelled the task: %1</source>
        <translation>O operador cancelou a tarefa: %1</translation>
    </message>
    <message>
        <location filename="../../tablet_app/texts.py" line="43" />
        <source>The Base Station is still taking me to %1: ask the operator.</source>
        <translation>A Estação Base continua a levar-me para %1: fale com o operador.</translation>
    </message>
    <message>
        <location filename="../../tablet_app/texts.py" line="46" />
        <source>Checking that I am at %1…</source>
        <translation>A confirmar que estou em %1…</translation>
    </message>
    <message>
        <location filename="../../tablet_app/texts.py" line="47" />
        <source>Thank you! I am at %1.</source>
        <translation>Obrigado! Estou em %1.</translation>
    </message>
    <message>
        <location filename="../../tablet_app/texts.py" line="48" />
        <source>I could not confirm that I am at %1. Please try another room.</source>
        <translation>Não consegui confirmar que estou em %1. Experimente outra sala, por favor.</translation>
    </message>
    <message>
        <location filename="../../tablet_app/texts.py" line="51" />
        <source>Thank you: the operator has your report of %1.</source>
        <translation>Obrigado: o operador recebeu o seu relato de %1.</translation>
    </message>
    <message>
        <location filename="../../tablet_app/texts.py" line="54" />
        <source>Request sent: I will bring “%1” from %2 to %3.</source>
        <translation>Pedido enviado: vou levar “%1” de %2 para %3.</translation>
    </message>
    <message>
        <location filename="../../tablet_app/texts.py" line="57" />
        <source>Thank you! I am on my way.</source>
        <translation>Obrigado! Vou a caminho.</translation>
    </message>
    <message>
        <location filename="../../tablet_app/texts.py" line="58" />
        <source>Declined. I will tell the person who asked.</source>
        <translation>Recusado. Vou avisar quem pediu.</translation>
    </message>
    <message>
        <location filename="../../tablet_app/texts.py" line="61" />
        <source>Guided tour requested.</source>
        <translation>Visita guiada pedida.</translation>
    </message>
    <message>
        <location filename="../../tablet_app/texts.py" line="62" />
        <source>The guided tour has ended.</source>
        <translation>A visita guiada terminou.</translation>
    </message>
    <message>
        <location filename="../../tablet_app/texts.py" line="63" />
        <source>Refused by the Base Station: %1</source>
        <translation>Recusado pela Estação Base: %1</translation>
    </message>
    <message>
        <location filename="../../tablet_app/texts.py" line="64" />
        <source>The Base Station says: %1</source>
        <translation>A Estação Base diz: %1</translation>
    </message>
    <message>
        <location filename="../../tablet_app/texts.py" line="65" />
        <source>Not connected: nothing was sent.</source>
        <translation>Sem ligação: nada foi enviado.</translation>
    </message>
    <message>
        <location filename="../../tablet_app/texts.py" line="79" />
        <source>Not connected to the Base Station</source>
        <translation>Sem ligação à Estação Base</translation>
    </message>
    <message>
        <location filename="../../tablet_app/texts.py" line="81" />
        <location filename="../../tablet_app/texts.py" line="106" />
        <source>Stopped by the operator</source>
        <translation>Parado pelo operador</translation>
    </message>
    <message>
        <location filename="../../tablet_app/texts.py" line="83" />
        <source>I do not know where I am</source>
        <translation>Não sei onde estou</translation>
    </message>
    <message>
        <location filename="../../tablet_app/texts.py" line="85" />
        <source>Finding my position…</source>
        <translation>A procurar a minha posição…</translation>
    </message>
    <message>
        <location filename="../../tablet_app/texts.py" line="87" />
        <source>Turning to find my position…</source>
        <translation>A rodar para encontrar a minha posição…</translation>
    </message>
    <message>
        <location filename="../../tablet_app/texts.py" line="88" />
        <source>On my way to %1</source>
        <translation>A caminho de %1</translation>
    </message>
    <message>
        <location filename="../../tablet_app/texts.py" line="90" />
        <source>On my way</source>
        <translation>A caminho</translation>
    </message>
    <message>
        <location filename="../../tablet_app/texts.py" line="94" />
        <source>%1 m to go</source>
        <translation>faltam %1 m</translation>
    </message>
    <message>
        <location filename="../../tablet_app/texts.py" line="97" />
        <source>Ready</source>
        <translation>Pronto</translation>
    </message>
    <message>
        <location filename="../../tablet_app/texts.py" line="98" />
        <source>Waiting to know where I am</source>
        <translation>À espera de saber onde estou</translation>
    </message>
    <message>
        <location filename="../../tablet_app/texts.py" line="99" />
        <source>Paused</source>
        <translation>Em pausa</translation>
    </message>
    <message>
        <location filename="../../tablet_app/texts.py" line="100" />
        <source>At a tour stop: waiting for you</source>
        <translation>Numa paragem da visita: à sua espera</translation>
    </message>
    <message>
        <location filename="../../tablet_app/texts.py" line="103" />
        <source>Waiting for an answer at the room</source>
        <translation>À espera de resposta na sala</translation>
    </message>
    <message>
        <location filename="../../tablet_app/texts.py" line="118" />
        <source>driving with the joystick</source>
        <translation>conduzir com o joystick</translation>
    </message>
    <message>
        <location filename="../../tablet_app/texts.py" line="119" />
        <source>trips to rooms</source>
        <translation>idas às salas</translation>
    </message>
    <message>
        <location filename="../../tablet_app/texts.py" line="120" />
        <source>guided tours</source>
        <translation>visitas guiadas</translation>
    </message>
    <message>
        <location filename="../../tablet_app/texts.py" line="121" />
        <source>requests</source>
        <translation>pedidos</translation>
    </message>
    <message>
        <location filename="../../tablet_app/texts.py" line="128" />
        <source>Not available now: %1</source>
        <translation>Indisponível agora: %1</translation>
    </message>
</context>
<context>
    <name>TabletWindow</name>
    <message>
        <location filename="../../tablet_app/main_window.py" line="413" />
        <source>The operator does not allow this now.</source>
        <translation>O operador não permite isto agora.</translation>
    </message>
    <message>
        <location filename="../../tablet_app/main_window.py" line="443" />
        <source>Connected to %1</source>
        <translation>Ligado a %1</translation>
    </message>
    <message>
        <location filename="../../tablet_app/main_window.py" line="446" />
        <source>%1 ms</source>
        <translation>%1 ms</translation>
    </message>
    <message>
        <location filename="../../tablet_app/main_window.py" line="448" />
        <source>Connecting to %1…</source>
        <translation>A ligar a %1…</translation>
    </message>
    <message>
        <location filename="../../tablet_app/main_window.py" line="450" />
        <source>Disconnected: reconnecting in %1 s</source>
        <translation>Desligado: a voltar a ligar dentro de %1 s</translation>
    </message>
    <message>
        <location filename="../../tablet_app/main_window.py" line="454" />
        <source>Disconnected</source>
        <translation>Desligado</translation>
    </message>
    <message>
        <location filename="../../tablet_app/main_window.py" line="497" />
        <source>Interbot Tablet</source>
        <translation>Tablet do Interbot</translation>
    </message>
    <message>
        <location filename="../../tablet_app/main_window.py" line="498" />
        <source>Help me!</source>
        <translation>Ajuda-me!</translation>
    </message>
    <message>
        <location filename="../../tablet_app/main_window.py" line="518" />
        <source>Operator</source>
        <translation>Operador</translation>
    </message>
    <message>
        <location filename="../../tablet_app/main_window.py" line="519" />
        <source>Leave the kiosk and close the tablet application?</source>
        <translation>Sair do modo quiosque e fechar a aplicação do tablet?</translation>
    </message>
</context>
</TS>