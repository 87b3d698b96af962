!> What every group reader of a deck shares (mlid_deck): a case that fails
!> keeps its message (fail); a group missing or refused by its namelist
!> read becomes a message that names the line and the culprit (group_status,
!> blame, assigned, group_line); text too long for its variable (too_long);
!> an option set by name (set_option); a list of choices for a message;
!> a line without its comment (strip_comment).
submodule (mlid_deck) mlid_deck_reader
  use mlid_text, only: comment_start, utf8_head
  use mlid_options, only: option_set
  use mlid_case, only: MAXSEG
  implicit none

contains

  !> After a group's namelist read: a missing group (an error when the job
  !> needs it) or a read error becomes the case's message.
  module procedure group_status
    integer :: k, j
    character(len=1) :: one
    if (ios < 0 .and. len(group_text(rd, group)) > 0) then
      ! never met (deck_scan found the group's /); but gfortran 12 takes the
      ! next internal namelist read after an end of file for an empty one
      ! (status 0, nothing read) unless another internal read comes between
      one = '1'
      read (one, *, iostat=j) k
      call fail(c, 'group &'//group//' (line '//itoa(group_line(rd%lines, rd%line0, group))// &
                '): its end was not found')
    else if (ios < 0 .and. required) then
      call fail(c, 'group &'//group//' is missing (job '''//trim(c%job)//''' needs it)')
    else if (ios > 0) then
      call fail(c, 'group &'//group//' (line '//itoa(group_line(rd%lines, rd%line0, group))// &
                '): '//blame(rd, group, iomsg))
    end if
  end procedure group_status

  !> A namelist read error in words a user can act on: the compiler names
  !> the token it could not take ("Cannot match namelist object name .5"):
  !> a name of the group that is not one of its namelist's, a number where a
  !> name should be (a value too many), or the rest of a bad value, the name
  !> assigned just before it on its line being the one with the bad value
  !> ("max_iter = 2.5"); or the variable whose index is out of range; or the
  !> assignment it counts as its item n (an integer too large, a number for
  !> a logical: by_item).
  function blame(rd, group, iomsg) result(text)
    type(reader_t), intent(in) :: rd
    character(len=*), intent(in) :: group, iomsg
    character(len=:), allocatable :: text, token, line
    integer :: p, k, q, e, b
    text = trim(iomsg)
    if (index(iomsg, ' item ') > 0) then
      text = by_item(rd, group, iomsg)
      return
    end if
    p = index(iomsg, 'namelist variable ')
    if (p > 0 .and. index(to_lower(iomsg), 'index') > 0) then
      k = assigned(rd, group, to_lower(trim(iomsg(p + 18:))), .true.)
      if (k == 0) return
      text = 'line '//itoa(rd%given(k)%line)//': '//trim(rd%given(k)%key)//'('// &
             trim(rd%given(k)%subscript)//'): '
      if (index(iomsg, 'out of range') > 0) then
        text = text//'the index lies outside '//trim(rd%given(k)%key)
      else
        text = text//'a deck''s lists take one index, NAME(i), NAME(i:j) or NAME(i:j:s) '// &
               '(a matrix is one list, row by row)'
      end if
      return
    end if
    p = index(iomsg, 'Repeat count too large for namelist object ')
    if (p > 0) then
      k = assigned(rd, group, to_lower(trim(iomsg(p + 43:))), .false.)
      if (k > 0) text = 'line '//itoa(rd%given(k)%line)//': '//trim(rd%given(k)%key)// &
                        ' is given more values than it takes (r*value is r values)'
      return
    end if
    p = index(iomsg, 'object name ')
    if (p == 0) return
    token = trim(iomsg(p + 12:))
    if (len(token) == 0) return
    k = assigned(rd, group, to_lower(token), .false.)
    if (k > 0) then
      text = 'line '//itoa(rd%given(k)%line)//': unknown name '//token//' in group &'//group
      return
    end if
    if (scan(token(1:1), '0123456789+-') == 1) then   ! a whole value: one too many
      text = 'a value stands where a name should be (read as '''//token//'''): a name '// &
             'given more values than it takes, or a name without ='
      return
    end if
    do k = group_line(rd%lines, rd%line0, group) - rd%line0 + 1, size(rd%lines)
      line = trim(strip_comment(rd%lines(k)%s))
      q = index(line, token)
      if (q == 0) cycle
      e = index(line(1:q - 1), '=', back=.true.)
      if (e == 0) exit
      b = scan(trim(line(1:e - 1)), ' ,', back=.true.)
      text = 'line '//itoa(rd%line0 + k - 1)//': bad value '''// &
             trim(adjustl(line(e + 1:q + len(token) - 1)))//''' for '// &
             trim(adjustl(line(b + 1:e - 1)))//' ('//trim(iomsg)//')'
      return
    end do
  end function blame

  !> gfortran's "Integer overflow while reading item 3", "Bad repeat count
  !> in item 2 of list input" (a number for a logical): its item n is the
  !> group's n-th assignment (NAME = values), the one named.
  function by_item(rd, group, iomsg) result(text)
    type(reader_t), intent(in) :: rd
    character(len=*), intent(in) :: group, iomsg
    character(len=:), allocatable :: text
    integer :: p, n, k, ios
    text = trim(iomsg)
    p = index(iomsg, ' item ') + 6
    n = 0
    ios = 1
    if (verify(iomsg(p:p), '0123456789') == 0) read (iomsg(p:), *, iostat=ios) n
    if (ios /= 0) return
    do k = 1, size(rd%given)
      if (rd%given(k)%group /= group) cycle
      n = n - 1
      if (n > 0) cycle
      associate (a => rd%given(k))
        if (index(iomsg, 'Integer overflow') > 0) then
          text = 'line '//itoa(a%line)//': '//trim(a%key)//' has a value beyond the '// &
                 'integers (-2147483648 to 2147483647)'
        else if (index(iomsg, 'Bad repeat count') > 0) then
          text = 'line '//itoa(a%line)//': '//trim(a%key)//' takes T or F (true or false), '// &
                 'not a number'
        else
          text = 'line '//itoa(a%line)//': '//trim(a%key)//': '//trim(iomsg)
        end if
      end associate
      return
    end do
  end function by_item

  !> The case's first assignment of name key in group (with a subscript
  !> when subscripted), 0 when none.
  integer function assigned(rd, group, key, subscripted)
    type(reader_t), intent(in) :: rd
    character(len=*), intent(in) :: group, key
    logical, intent(in) :: subscripted
    integer :: k
    assigned = 0
    do k = 1, size(rd%given)
      if (rd%given(k)%group /= group .or. rd%given(k)%key /= key) cycle
      if (subscripted .and. len_trim(rd%given(k)%subscript) == 0) cycle
      assigned = k
      return
    end do
  end function assigned

  !> Whether quoted text given to one of keys in group is longer than room,
  !> the bytes its variable holds (UTF-8: one to four a character) (the namelist read would cut it
  !> without a word): the case fails naming key, line and room.
  module procedure too_long
    integer :: k
    too_long = .false.
    do k = 1, size(rd%given)
      associate (a => rd%given(k))
        if (a%group /= group .or. all(a%key /= keys) .or. a%longest <= room) cycle
        call fail(c, 'line '//itoa(a%line)//': a value of '//trim(a%key)//' in group &'// &
                  group//' is longer than its '//itoa(room)//' bytes')
        too_long = .true.
        return
      end associate
    end do
  end procedure too_long

  !> The text of group in the case ('' when none): what its namelist read
  !> is given.
  module procedure group_text
    integer :: k
    text = ''
    do k = 1, size(rd%spans)
      if (rd%spans(k)%name == group) text = rd%texts(k)%s
    end do
  end procedure group_text

  !> Whether scalar key of group was given a value (not a null).
  module procedure is_given
    integer :: st(1)
    st = element_states(rd%given, group, key, 1)
    is_given = st(1) == GIVEN
  end procedure is_given

  !> Lists with more than room entries (room: MAXSEG manoeuvres, MAXFREE
  !> free parameters).
  module procedure at_most
    integer :: k, m
    do k = 1, size(keys)
      m = last_element(rd%given, group, trim(keys(k)))
      if (m <= room) cycle
      call fail(c, 'group &'//group//': '//trim(keys(k))//' has '//itoa(m)//' entries; a '// &
                'case takes at most '//itoa(room)//' '//what)
      return
    end do
  end procedure at_most

  !> The first m entries of v, m the last element of list key the deck
  !> gave (list_length); a null keeps v's entry, its default.  Elements
  !> named by index alone in a list of full entries with a default: all
  !> full entries, those not named keeping their default.
  module procedure take_list
    integer :: m
    if (present(full) .and. has_default) then
      if (by_index(rd, group, key)) then
        m = last_element(rd%given, group, key)
        if (m > min(full, size(v))) then
          call beyond(c, group, key, m, min(full, size(v)))
          allocate (out(0))
        else
          out = v(1:min(full, size(v)))
        end if
        return
      end if
    end if
    call list_length(rd, c, group, key, size(v), has_default, m)
    out = v(1:m)
  end procedure take_list

  !> key(m) given, key taking n values.
  subroutine beyond(c, group, key, m, n)
    type(case_t), intent(inout) :: c
    character(len=*), intent(in) :: group, key
    integer, intent(in) :: m, n
    call fail(c, 'group &'//group//': '//key//'('//itoa(m)//') is given, and '//key// &
              ' takes '//itoa(n)//' value'//trim(merge('s', ' ', n /= 1)))
  end subroutine beyond

  module procedure by_index
    integer :: k
    by_index = .false.
    do k = 1, size(rd%given)
      if (rd%given(k)%group /= group .or. rd%given(k)%key /= key) cycle
      if (len_trim(rd%given(k)%subscript) == 0) then
        by_index = .false.
        return
      end if
      by_index = .true.
    end do
  end procedure by_index

  !> The last element of list key (of room n) the deck gave, a value or a
  !> null (0: none); an element left out before it, or a null where the
  !> list has no default, fails the case.
  module procedure list_length
    integer :: st(n), j
    st = element_states(rd%given, group, key, n)
    m = findloc(st /= ABSENT, .true., 1, back=.true.)
    j = findloc(st(1:m) == ABSENT, .true., 1)
    if (j > 0) then
      call fail(c, 'group &'//group//': '//key//'('//itoa(j)//') is left out, '//key// &
                '('//itoa(m)//') given (a list is given from its first element on)')
    else if (.not. has_default .and. any(st(1:m) == NULLED)) then
      call fail(c, 'group &'//group//': '//key//'('//itoa(findloc(st(1:m) == NULLED, .true., &
                1))//') is a null value, and '//key//' has no default to keep')
    end if
  end procedure list_length

  module procedure fail
    c%status = MLID_ERR_INPUT
    c%msg = text
  end procedure fail

  !> Set an option of the case by name from the deck's text (the core's
  !> option table checks the name and the value).
  module procedure set_option
    character(len=msg_len) :: msg
    integer :: status
    call option_set(c%iopt, c%ropt, name, text, status, msg)
    if (status /= MLID_OK) call fail(c, where//trim(msg))
  end procedure set_option


  !> The line without its comment (from the first '!' outside quotes:
  !> mlid_text's comment_start).
  module procedure strip_comment
    s = line(1:comment_start(line) - 1)
  end procedure strip_comment

  !> Line number of the first &group in the case (for messages).
  integer function group_line(lines, line0, group)
    type(line_t), intent(in) :: lines(:)
    character(len=*), intent(in) :: group
    integer, intent(in) :: line0
    integer :: k
    group_line = line0
    do k = 1, size(lines)
      if (index(to_lower(strip_comment(lines(k)%s)), '&'//group) > 0) then
        group_line = line0 + k - 1
        return
      end if
    end do
  end function group_line

end submodule mlid_deck_reader
