"""The servo-bus layer: `ServoBus` (servo_bus), vendor drivers on the vendors' SDKs (dynamixel,
feetech, over the request/reply engine in sdk_bus), wire codecs (protocol), control tables as
data (control_table), the bus time budget (budget), a wire decoder for logs (wire_log), and the
byte-level virtual bus (virtual). Knows nothing of gaits or robots' legs; `hardware.play` builds
on it."""
