"""The service's device answers as this client reads them (generated: see clients/schemas/__init__.py)."""

from __future__ import annotations

import math
from typing import Annotated

from pydantic import Field

from clients.schemas.answer import Answer


class Cable(Answer):
    """
    Two-mass cable transmission of the chapter's §4 (Fig. 11b, eq. 15-18).
    """

    motor_mass: Annotated[float, Field(description="m_r, mass pushed by the motor [kg or kg·m²]")]
    motor_damping: Annotated[float, Field(description="b_r, damping of the motor mass to ground [N·s/m or N·m·s/rad]")]
    body_mass: Annotated[float, Field(description="m_d, mass pushed by the user [kg or kg·m²]")]
    body_damping: Annotated[float, Field(description="b_d, damping of the body mass to ground [N·s/m or N·m·s/rad]")]
    stiffness: Annotated[float, Field(description="k_c, cable stiffness [N/m or N·m/rad]")]
    damping: Annotated[float, Field(description="b_c, cable damping [N·s/m or N·m·s/rad]")]

    # Added by hand (the presets table shows it): eq. 24, as models.device.Cable has it.
    @property
    def natural_frequency(self) -> float:
        """ω_n of eq. 24 [rad/s]: the first vibration mode of the transmission."""
        m_r, m_d = self.motor_mass, self.body_mass
        return math.sqrt(self.stiffness * (m_r + m_d) / (m_r * m_d))


class ForceSensor(Answer):
    """
    Anti-aliasing filter of the force sensor, G_f(s) = 1/(1 + T_f s) (eq. 31).
    """

    time_constant: Annotated[float, Field(description="T_f [s]; 0 means no filter")]


class Human(Answer):
    """
    The user's grasp Z_h(s) = m_h s² + b_h s + k_h (eq. 30).
    """

    mass: Annotated[float, Field(description="m_h [kg]")]
    damping: Annotated[float, Field(description="b_h [N·s/m]")]
    stiffness: Annotated[float, Field(description="k_h [N/m]")]


class Device(Answer):
    """
    A haptic device in one axis.

    Rigid model: ``mass`` m and ``damping`` b (eq. 14).  With a ``cable`` block the
    two-mass model of §4 is used and m, b are the sums m_r + m_d, b_r + b_d.
    ``preset`` names one of :data:`PRESETS`; the other fields override it, and an
    explicit ``null`` removes a block of the preset (``"cable": null`` gives the
    rigid model of the same device).
    """

    preset: Annotated[str | None, Field(description="name of a preset; other fields override it")] = None
    mass: Annotated[float, Field(description="m, total moving mass [kg or kg·m²]")]
    damping: Annotated[float, Field(description="b, total physical damping [N·s/m or N·m·s/rad]")]
    sample_time: Annotated[float, Field(description="T, sample period [s]")] = 0.001
    delay: Annotated[float, Field(description="t_d, total loop delay [s], any real ≥ 0")] = 0.0
    cable: Annotated[Cable | None, Field(description="two-mass cable model (§4)")] = None
    human: Annotated[Human | None, Field(description="the user's grasp Z_h (eq. 30)")] = None
    force_sensor: Annotated[ForceSensor | None, Field(description="force-sensor filter G_f (eq. 31)")] = None
    encoder_resolution: Annotated[
        float | None, Field(description="q, encoder resolution on the motor side [m per count, or rad]")
    ] = None
    coulomb_friction: Annotated[float | None, Field(description="f_c, Coulomb friction on the motor-side mass [N]")] = None
    travel: Annotated[float | None, Field(description="range of motion the encoder covers [m, or rad]")] = None
