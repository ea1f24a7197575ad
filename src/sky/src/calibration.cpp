// implementation pending in this change
