!> The text of one deck case checked as a whole before the compiler's
!> namelist reads take its groups: a namelist read takes the first &group
!> it finds and stops at its /, so what lies outside the groups, a group not
!> closed, a name given twice (the last value wins) or a word it reads by
!> its first letter (tomato: .true.) would otherwise pass silently.
!>
!> The syntax taken: groups &name ... / (not $name ... $end, nor &end);
!> assignments NAME = values or NAME(i) = values or NAME(i:j) = values, the
!> values separated by commas or blanks (two commas: a null value), each
!> a number, r*number, r*'text', quoted
!> text or a logical (T, F, true, false, any case, with or without periods).
module mlid_deck_scan
  use mlid_kinds, only: MLID_OK, MLID_ERR_INPUT
  use mlid_text, only: to_lower, itoa, line_t
  implicit none
  private
  public :: deck_scan, assignment_t

  integer, parameter :: WORDLEN = 64

  !> One assignment of a group: its group and name, where it starts (first =
  !> -1 when its subscript is not of one dimension), the end of its section
  !> (0: none), the values given, its line and the longest quoted text among
  !> them (a namelist read cuts text to its variable's room without a word).
  type :: assignment_t
    character(len=WORDLEN) :: group = '', key = '', subscript = ''
    integer :: first = 1, section_end = 0, n = 0, line = 0, longest = 0
  end type assignment_t

  character(len=*), parameter :: BLANKS = ' '//achar(9)
  !> What the scan met last in an assignment's values (for null values)
  integer, parameter :: AFTER_EQUALS = 1, AFTER_VALUE = 2, AFTER_COMMA = 3
  character(len=*), parameter :: WORD_CHARS = &
    'abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ_0123456789'

contains

  !> Check a case's lines (comments stripped; the first is number line0)
  !> against the syntax above; groups: ' name name ... ', the groups known.
  !> status /= MLID_OK: msg is the first problem, naming its line.
  !> every: the assignments of all groups, in order.
  subroutine deck_scan(lines, line0, groups, status, msg, every)
    type(line_t), intent(in) :: lines(:)
    integer, intent(in) :: line0
    character(len=*), intent(in) :: groups
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    type(assignment_t), allocatable, intent(out) :: every(:)
    type(assignment_t), allocatable :: given(:)
    character(len=:), allocatable :: s, seen, group, word
    integer :: k, p, e, ln, gline, after
    logical :: ingroup, eq_next

    status = MLID_OK
    msg = ''
    seen = ' '
    group = ''
    gline = 0
    after = 0
    eq_next = .false.
    ingroup = .false.
    allocate (given(0), every(0))
    do k = 1, size(lines)
      s = lines(k)%s
      ln = line0 + k - 1
      p = 1
      do
        p = next_char(s, p)
        if (p == 0) exit
        select case (s(p:p))
        case (',')
          if (.not. ingroup) call outside(s, p, ln)
          if (size(given) > 0) call null_value(given(size(given)))
          p = p + 1
        case ('/')
          if (.not. ingroup) call outside(s, p, ln)
          ingroup = .false.
          p = p + 1
        case ('&', '$')
          e = word_end(s, p + 1)
          word = s(p + 1:e - 1)
          if (s(p:p) == '$' .or. to_lower(word) == 'end') then
            call problem('line '//itoa(ln)//': '''//s(p:e - 1)//''': a group starts with '// &
                         '&name and ends with / ($name ... $end and &end are not read)')
          else if (ingroup) then
            call not_closed()
          else if (index(groups, ' '//to_lower(word)//' ') == 0 .or. len(word) == 0) then
            call problem('line '//itoa(ln)//': unknown group &'//word//' (groups are '// &
                         group_list(groups)//')')
          else if (index(seen, ' '//to_lower(word)//' ') > 0) then
            ! a compiler's namelist read would take the first and ignore the rest
            call problem('line '//itoa(ln)//': group &'//word//' given twice in one case')
          else if (quoted_bang(s(1:p - 1))) then
            ! the namelist read, looking for a group, skips a line from its first !
            call problem('line '//itoa(ln)//': start &'//word//' on a line of its own (a ! '// &
                         'in quoted text before it hides it from the namelist read)')
          end if
          if (status /= MLID_OK) return
          seen = seen//to_lower(word)//' '
          group = word
          gline = ln
          ingroup = .true.
          every = [every, given]
          deallocate (given)
          allocate (given(0))
          p = e
        case ('=')           ! the = of a name that ends the line before
          if (.not. (ingroup .and. eq_next)) then
            if (.not. ingroup) call outside(s, p, ln)
            if (ingroup) call problem('line '//itoa(ln)//': '''//shown(s(p:))// &
                                      ''' in group &'//group//' is no NAME = value')
          end if
          eq_next = .false.
          p = p + 1
        case ('''', '"')
          if (.not. ingroup) call outside(s, p, ln)
          if (status == MLID_OK) call value(s, p, ln, given)
        case default
          if (.not. ingroup) call outside(s, p, ln)
          if (status == MLID_OK) call name_or_value(s, p, ln, given)
        end select
        if (status /= MLID_OK) return
      end do
    end do
    if (ingroup) call not_closed()
    every = [every, given]

  contains

    subroutine problem(text)
      character(len=*), intent(in) :: text
      status = MLID_ERR_INPUT
      msg = text
    end subroutine problem

    subroutine not_closed()
      call problem('group &'//group//' at line '//itoa(gline)//' is not closed with /')
    end subroutine not_closed

    !> Text where no group is open.
    subroutine outside(s, p, ln)
      character(len=*), intent(in) :: s
      integer, intent(in) :: p, ln
      call problem('line '//itoa(ln)//': '''//shown(s(p:))//''' is outside any group (a '// &
                   'group is &name ... /, a comment starts with !)')
    end subroutine outside

    !> At p, a name (NAME, NAME(...), then =: an assignment) or a value.
    subroutine name_or_value(s, p, ln, given)
      character(len=*), intent(in) :: s
      integer, intent(inout) :: p
      integer, intent(in) :: ln
      type(assignment_t), allocatable, intent(inout) :: given(:)
      type(assignment_t) :: a
      integer :: e, q, j
      e = word_end(s, p)
      q = next_char(s, e)
      a%key = to_lower(s(p:e - 1))
      if (e > p .and. q > 0) then
        if (s(q:q) == '(') then
          j = index(s(q:), ')')
          if (j > 0) then
            a%subscript = s(q + 1:q + j - 2)
            q = next_char(s, q + j)
          end if
        end if
      end if
      if (e > p .and. q == 0) eq_next = equals_next(k)
      if (e == p .or. (q == 0 .and. .not. eq_next)) then
        call value(s, p, ln, given)
        return
      end if
      if (q > 0) then
        if (s(q:q) /= '=') then
          call value(s, p, ln, given)
          return
        end if
      end if
      a%line = ln
      a%group = to_lower(group)
      call elements(a)
      do j = 1, size(given)
        if (given(j)%key /= a%key) cycle
        if (overlap(given(j), a)) then
          call problem('line '//itoa(ln)//': '//trim(s(p:e - 1))//trim(paren(a%subscript))// &
                       ' given twice in group &'//group//' (first at line '// &
                       itoa(given(j)%line)//')')
          return
        end if
      end do
      given = [given, a]
      after = AFTER_EQUALS
      p = len(s) + 1                     ! the = on the next line: eq_next
      if (q > 0) p = q + 1
    end subroutine name_or_value

    !> Whether the first text after line kl opens with = (a name ending
    !> its line, its = on the next).
    logical function equals_next(kl)
      integer, intent(in) :: kl
      integer :: j, c
      equals_next = .false.
      do j = kl + 1, size(lines)
        c = next_char(lines(j)%s, 1)
        if (c == 0) cycle
        equals_next = lines(j)%s(c:c) == '='
        return
      end do
    end function equals_next

    !> A comma: after = or after another comma it stands for a null value,
    !> which keeps its element as it was: one at the start moves where the
    !> assignment starts setting (x0 = , 0.02 sets x0(2) alone), one later
    !> is a position counted.
    subroutine null_value(a)
      type(assignment_t), intent(inout) :: a
      if (after == AFTER_EQUALS .or. after == AFTER_COMMA) then
        if (a%n == 0 .and. a%first > 0) then
          a%first = a%first + 1
        else
          a%n = a%n + 1
        end if
      end if
      after = AFTER_COMMA
    end subroutine null_value

    !> A value at p (quoted text, or an unquoted word up to a blank, a comma
    !> or /), counted to the last assignment; p moves past it.
    subroutine value(s, p, ln, given)
      character(len=*), intent(in) :: s
      integer, intent(inout) :: p
      integer, intent(in) :: ln
      type(assignment_t), intent(inout) :: given(:)
      integer :: e, n
      n = 1
      e = scan(s(p:), '*')
      if (e > 1 .and. verify(s(p:p + e - 2), '0123456789') == 0 .and. p + e <= len(s)) then
        if (scan(s(p + e:p + e), '''"') == 1) then      ! r*'text': r copies of the text
          read (s(p:p + e - 2), *) n
          p = p + e
        end if
      end if
      if (s(p:p) == '''' .or. s(p:p) == '"') then
        e = quote_end(s, p)
        if (e == 0) then
          call problem('line '//itoa(ln)//': the quote of '//shown(s(p:))// &
                       ' is not closed on its line')
          return
        end if
        call group_in_text(s(p:e), ln)
        if (status /= MLID_OK) return
        if (size(given) > 0) given(size(given))%longest = max(given(size(given))%longest, &
                                                              text_length(s(p:e)))
        e = e + 1
      else
        e = scan(s(p:), BLANKS//',/''"')
        if (e == 0) then
          e = len(s) + 1
        else
          e = p + e - 1
        end if
        if (.not. plain_value(s(p:e - 1), n)) then
          if (size(given) == 0) then
            call problem('line '//itoa(ln)//': '''//shown(s(p:))//''' in group &'//group// &
                         ' is no NAME = value')
          else
            call problem('line '//itoa(ln)//': bad value '//s(p:e - 1)//' for '// &
                         trim(given(size(given))%key)//' in group &'//group//': not a '// &
                         'number, not quoted text and not a logical (.true., .false., T, F, '// &
                         'true or false, with or without periods)')
          end if
          return
        end if
      end if
      if (size(given) == 0) then
        call problem('line '//itoa(ln)//': '''//shown(s(p:))//''' in group &'//group// &
                     ' is no NAME = value')
        return
      end if
      given(size(given))%n = given(size(given))%n + n
      after = AFTER_VALUE
      p = e
    end subroutine value

    !> A compiler's namelist read finds a group by &name or $name anywhere,
    !> quoted or not: quoted text may not hold a group's name so.
    subroutine group_in_text(text, ln)
      character(len=*), intent(in) :: text
      integer, intent(in) :: ln
      integer :: j, e
      do j = 1, len(text) - 1
        if (scan(text(j:j), '&$') /= 1) cycle
        e = word_end(text, j + 1)
        if (e == j + 1) cycle
        if (index(groups, ' '//to_lower(text(j + 1:e - 1))//' ') == 0) cycle
        call problem('line '//itoa(ln)//': quoted text '//shown(text)//' holds '''// &
                     text(j:e - 1)//''', which the namelist reads would take for the group')
        return
      end do
    end subroutine group_in_text

  end subroutine deck_scan

  !> The length of quoted text (its quotes off, a doubled quote one).
  integer function text_length(quoted)
    character(len=*), intent(in) :: quoted
    integer :: k
    text_length = 0
    k = 2
    do while (k < len(quoted))
      text_length = text_length + 1
      if (quoted(k:k) == quoted(1:1)) k = k + 1
      k = k + 1
    end do
  end function text_length

  !> Whether text holds a ! inside quotes.
  logical function quoted_bang(text)
    character(len=*), intent(in) :: text
    integer :: k, e
    quoted_bang = .false.
    k = 1
    do while (k <= len(text))
      if (scan(text(k:k), '''"') == 1) then
        e = quote_end(text, k)
        if (e == 0) e = len(text)
        if (index(text(k:e), '!') > 0) quoted_bang = .true.
        k = e
      end if
      k = k + 1
    end do
  end function quoted_bang

  !> Where an assignment starts, from its subscript: (i) or (i:j) or none.
  subroutine elements(a)
    type(assignment_t), intent(inout) :: a
    integer :: c, i, j, ios
    a%first = 1
    if (len_trim(a%subscript) == 0) return
    c = index(a%subscript, ':')
    if (c == 0) then
      read (a%subscript, *, iostat=ios) i
      j = 0
    else
      read (a%subscript(1:c - 1), *, iostat=ios) i
      if (ios == 0) read (a%subscript(c + 1:), *, iostat=ios) j
    end if
    if (ios /= 0 .or. index(a%subscript, ',') > 0) then
      a%first = -1           ! not one dimension: the namelist read says what is wrong
      return
    end if
    a%first = i
    if (c > 0) a%section_end = max(j, i)
  end subroutine elements

  !> Whether two assignments of one name set a common element.
  logical function overlap(a, b)
    type(assignment_t), intent(in) :: a, b
    if (a%first < 0 .or. b%first < 0) then
      overlap = a%subscript == b%subscript
    else
      overlap = max(a%first, b%first) <= min(last(a), last(b))
    end if
  end function overlap

  !> The last element an assignment sets: its section's, else one per value.
  integer function last(a)
    type(assignment_t), intent(in) :: a
    last = a%first + max(a%n, 1) - 1
    if (a%section_end > 0) last = a%section_end
  end function last

  !> An unquoted value: a number, r*number, r* (r null values), a
  !> logical, nan or inf (the finite checks are the readers'); n, the
  !> values it stands for.
  logical function plain_value(w, n)
    character(len=*), intent(in) :: w
    integer, intent(out) :: n
    character(len=len(w)) :: v
    integer :: star, ios
    n = 1
    v = w
    star = index(w, '*')
    if (star > 1) then
      read (w(1:star - 1), '(i12)', iostat=ios) n
      plain_value = ios == 0 .and. verify(w(1:star - 1), '0123456789') == 0 .and. n > 0
      if (.not. plain_value) return
      v = w(star + 1:)
      if (len_trim(v) == 0) return
    end if
    plain_value = is_number(trim(v)) .or. is_logical(trim(v)) .or. &
      any(to_lower(trim(v)) == [character(len=9) :: 'nan', 'inf', '+inf', '-inf', &
      'infinity', '+infinity', '-infinity'])
  end function plain_value

  !> A logical as Fortran writes one: t, f, true or false, any case, with
  !> or without a period before and after (.t., .false, T.): not any word
  !> that starts with t or f, as the namelist read would take it.
  logical function is_logical(w)
    character(len=*), intent(in) :: w
    integer :: a, b
    a = 1
    b = len(w)
    if (b > 0) then
      if (w(1:1) == '.') a = 2
    end if
    if (b >= a) then
      if (w(b:b) == '.') b = b - 1
    end if
    is_logical = any(to_lower(w(a:b)) == [character(len=5) :: 't', 'f', 'true', 'false'])
  end function is_logical

  !> [sign] digits [. digits] [e|d [sign] digits], at least one digit.
  logical function is_number(w)
    character(len=*), intent(in) :: w
    integer :: p, nd
    is_number = .false.
    p = 1
    nd = 0
    if (len(w) == 0) return
    if (scan(w(1:1), '+-') == 1) p = 2
    call digits()
    if (p <= len(w)) then
      if (w(p:p) == '.') then
        p = p + 1
        call digits()
      end if
    end if
    if (nd == 0) return
    if (p <= len(w)) then
      if (scan(w(p:p), 'eEdD') /= 1) return
      p = p + 1
      if (p <= len(w)) then
        if (scan(w(p:p), '+-') == 1) p = p + 1
      end if
      nd = 0
      call digits()
      if (nd == 0) return
    end if
    is_number = p > len(w)
  contains
    subroutine digits()
      do while (p <= len(w))
        if (scan(w(p:p), '0123456789') /= 1) exit
        p = p + 1
        nd = nd + 1
      end do
    end subroutine digits
  end function is_number

  !> The first character at or after p that is not blank (0: none).
  integer function next_char(s, p)
    character(len=*), intent(in) :: s
    integer, intent(in) :: p
    if (p > len(s)) then
      next_char = 0
      return
    end if
    next_char = verify(s(p:), BLANKS)
    if (next_char > 0) next_char = p + next_char - 1
  end function next_char

  !> Where the word (letters, digits, _) starting at p ends (one after it).
  integer function word_end(s, p)
    character(len=*), intent(in) :: s
    integer, intent(in) :: p
    word_end = len(s) + 1
    if (p > len(s)) return
    if (verify(s(p:), WORD_CHARS) > 0) word_end = p + verify(s(p:), WORD_CHARS) - 1
  end function word_end

  !> The closing quote of the text quoted at p (a doubled quote is one
  !> quote of the text); 0 when the line ends first.
  integer function quote_end(s, p)
    character(len=*), intent(in) :: s
    integer, intent(in) :: p
    integer :: k
    quote_end = 0
    k = p + 1
    do while (k <= len(s))
      if (s(k:k) == s(p:p)) then
        if (k < len(s)) then
          if (s(k + 1:k + 1) == s(p:p)) then
            k = k + 2
            cycle
          end if
        end if
        quote_end = k
        return
      end if
      k = k + 1
    end do
  end function quote_end

  !> Text for a message: trimmed, at most 40 characters.
  function shown(s) result(t)
    character(len=*), intent(in) :: s
    character(len=:), allocatable :: t
    t = trim(s)
    if (len(t) > 40) t = t(1:37)//'...'
  end function shown

  function paren(s) result(t)
    character(len=*), intent(in) :: s
    character(len=:), allocatable :: t
    t = ''
    if (len_trim(s) > 0) t = '('//trim(s)//')'
  end function paren

  !> ' case model ... ' -> '&case, &model, ...'
  function group_list(groups) result(t)
    character(len=*), intent(in) :: groups
    character(len=:), allocatable :: t
    integer :: p, e
    t = ''
    p = next_char(groups, 1)
    do while (p > 0)
      e = index(groups(p:), ' ') + p - 1
      if (len(t) > 0) t = t//', '
      t = t//'&'//groups(p:e - 1)
      p = next_char(groups, e)
    end do
  end function group_list

end module mlid_deck_scan
