"""The exception tree of campaigns: everything a campaign refuses is a `CampaignError`, whose
message says what was expected, what came and where.

Tree::

    CampaignError (RuntimeError)     a campaign cannot start or go on: no scheduler at
                                     --scheduler, a disk that refuses its records
    └── CampaignFolderError          the folder holds another campaign, unreadable records, or
                                     no campaign to resume
"""

from __future__ import annotations


class CampaignError(RuntimeError):
    """A campaign cannot start, resume or be read: the message says what was expected, what
    came and where."""


class CampaignFolderError(CampaignError):
    """The output folder holds something else than the campaign asked for: another campaign's
    records, records that cannot be read, or a campaign to resume that is not there."""
